// Hostile scene text: nesting, size, long strings and arrays are refused by a linear check
// before the TOML parser sees them (the parser recurses per nesting level and takes quadratic
// time over long arrays), and ordinary files are not affected.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/text_limits.h"
#include "engine/temp_path.h"

namespace dembuf {
namespace {

// The message of the SceneError that loading `text` throws ("" when it loads).
std::string Refusal(const std::string& text) {
  try {
    LoadSceneText(text, "scene file \"hostile.toml\"");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

std::string Repeat(const std::string& piece, int times) {
  std::string out;
  for (int k = 0; k < times; ++k) out += piece;
  return out;
}

TEST(TextLimits, DeepArraysAreRefusedNamingTheLineAndLimit) {
  // 20,000 nested arrays overflowed the parser's stack (a segmentation fault).
  const std::string text =
      "[output]\nsnapshot_times_s = " + Repeat("[", 20000) + Repeat("]", 20000) + "\n";
  const std::string why = Refusal(text);
  EXPECT_NE(why.find("hostile.toml\": line 2: arrays and tables nested more than 8 deep"),
            std::string::npos)
      << why;
}

TEST(TextLimits, DeepInlineTablesAreRefused) {
  const std::string text =
      "[bed]\nthickness_m = " + Repeat("{a=", 20000) + "1" + Repeat("}", 20000) + "\n";
  EXPECT_NE(Refusal(text).find("nested more than 8 deep"), std::string::npos) << Refusal(text);
}

TEST(TextLimits, LongArraysManyKeysLongStringsAndBigTextsAreRefused) {
  const std::string array =
      "[output]\nsnapshot_times_s = [" + Repeat("0.001, ", 40000) + "0.001]\n";
  EXPECT_NE(Refusal(array).find("more than 1024 elements; at most 1024"), std::string::npos)
      << Refusal(array);
  std::string keys = "[bed]\n";
  for (int k = 0; k < 2000; ++k) keys.append("k").append(std::to_string(k)).append(" = 1\n");
  EXPECT_NE(Refusal(keys).find("line 1002: more than 1000 key = value pairs"), std::string::npos)
      << Refusal(keys);
  const std::string string = std::string("[bed]\nimport = \"").append(5000, 'x').append("\"\n");
  EXPECT_NE(Refusal(string).find("line 2: a string of 5000 bytes; at most 4096 bytes"),
            std::string::npos)
      << Refusal(string);
  const std::string big = std::string("# ").append(2 << 20, 'x').append("\n");
  EXPECT_NE(Refusal(big).find("2097155 bytes; at most 1048576 bytes"), std::string::npos)
      << Refusal(big);
}

TEST(TextLimits, BracketsInStringsAndCommentsDoNotCount) {
  // Nine brackets in a comment, a basic string, a literal string and multi-line strings with
  // quotes and escapes inside: none is nesting, so each file reaches the field checks.
  const std::string nine = std::string(9, '[');
  for (const std::string& value :
       {"\"" + nine + "\"", "'" + nine + "'", "\"\"\"" + nine + "\n\\\"\"\" \"\"\"",
        "'''" + nine + "\n'' '''", "\"a\\\"" + nine + "\""}) {
    const std::string text = "# " + nine + "\n[material]\nshear_stiffness = " + value + "\n";
    const std::string why = Refusal(text);
    EXPECT_NE(why.find("material.shear_stiffness: "), std::string::npos) << value << ": " << why;
    EXPECT_NE(why.find("is not allowed"), std::string::npos) << value << ": " << why;
  }
}

TEST(TextLimits, OrdinaryScenesAndPrintedScenesPass) {
  for (const Preset& preset : Presets())
    EXPECT_NO_THROW(PresetScene(std::string(preset.name))) << preset.name;
  std::ostringstream printed;
  Scene scene;
  scene.output.snapshot_times_s.assign(1024, 0.001);
  PrintScene(scene, printed);
  EXPECT_EQ(LoadSceneText(printed.str(), "printed").output.snapshot_times_s.size(), 1024u);
}

TEST(TextLimits, OverridesAreBoundedToo) {
  Scene scene;
  std::string list = "0.001";
  for (int k = 0; k < 1100; ++k) list += ",0.001";
  try {
    SetSceneField(scene, "output.snapshot_times_s", list);
    FAIL() << "a list of 1101 values was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "output.snapshot_times_s");
    EXPECT_NE(std::string(e.what()).find("1101 values; at most 1024"), std::string::npos)
        << e.what();
  }
  try {
    SetSceneField(scene, "bed.import", std::string(5000, 'x'));
    FAIL() << "a 5000-byte path was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed.import");
    EXPECT_NE(std::string(e.what()).find("5000 bytes; at most 4096"), std::string::npos)
        << e.what();
  }
}

TEST(TextLimits, FilesAreReadOnlyUpToTheirLimit) {
  const std::string path = test::TempPath("big.toml");
  std::ofstream(path) << std::string(2000, '#');
  EXPECT_EQ(ReadBoundedFile(path, 2000, "scene file").size(), 2000u);
  try {
    ReadBoundedFile(path, 1999, "scene file");
    FAIL();
  } catch (const InputLimitError& e) {
    EXPECT_NE(std::string(e.what()).find("holds 2000 bytes; at most 1999 bytes"), std::string::npos)
        << e.what();
  }
  // A device is not a file: never read (it would never end).
  EXPECT_THROW(ReadBoundedFile("/dev/zero", 1 << 20, "scene file"), InputLimitError);
  try {
    LoadSceneFile("/dev/zero");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("not a file"), std::string::npos) << e.what();
  }
}

TEST(DisplayText, ControlsBidiAndInvalidUtf8AreRefusedAndShownAsQuestionMarks) {
  EXPECT_EQ(DisplayTextProblem("E2 H = 2 cm, \xc2\xb5m beads \xe6\xb2\x99"), "");
  EXPECT_EQ(DisplayTextProblem("ok\tno"), "holds the control character U+0009 (byte 3)");
  EXPECT_EQ(DisplayTextProblem("a\x7f"), "holds the control character U+007F (byte 2)");
  // U+009B, the C1 control sequence introducer: a terminal reads it as ESC [.
  EXPECT_EQ(DisplayTextProblem("job\xc2\x9b"
                               "31m"),
            "holds the control character U+009B (byte 4)");
  // U+202E right-to-left override: "job_fdp.exe" shown as "job_exe.pdf".
  EXPECT_EQ(DisplayTextProblem("job_\xe2\x80\xae"
                               "fdp.exe"),
            "holds the bidirectional control U+202E (byte 5)");
  EXPECT_EQ(DisplayTextProblem("\xe2\x81\xa6x"), "holds the bidirectional control U+2066 (byte 1)");
  EXPECT_EQ(DisplayTextProblem("caf\xc3"), "is not UTF-8 (byte 4)");
  EXPECT_EQ(DisplayTextProblem("\xc0\xaf"), "is not UTF-8 (byte 1)");  // an overlong '/'
  EXPECT_EQ(PrintableText("job\xc2\x9b"
                          "31m_\xe2\x80\xae"
                          "fdp\xff \xc2\xb5m"),
            "job?31m_?fdp? \xc2\xb5m");
}

}  // namespace
}  // namespace dembuf
