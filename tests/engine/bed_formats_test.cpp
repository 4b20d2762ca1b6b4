// Beds from every code: dembuf's text (with and without a header naming columns and units),
// LAMMPS data files (what `dembuf bed export --format lammps` writes) and LAMMPS dumps, read
// back to the same beads; malformed files refused naming the line and what was expected.
#include <gtest/gtest.h>

#include <sstream>

#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/scene/errors.h"

namespace dembuf {
namespace {

Scene SmallCylinder() {
  Scene scene;
  scene.cylinder.radius_m = 0.025;
  return scene;
}

// Three beads of 2 mm radius resting apart on the plate, with digits that a short print
// would lose.
dem::ParticleState ThreeBeads(const Scene& scene) {
  dem::ParticleState beads;
  const double r = 0.002;
  for (int k = 0; k < 3; ++k) {
    const double radius = r * (1.0 + 0.01 * k);
    beads.Add(dem::Vec3(0.0051234567891234 * (k - 1), 0.0003333333333333 * k, radius + 1e-7 * k),
              radius, scene.material.density_kg_m3);
  }
  return beads;
}

ImportedBed Read(const std::string& text, const Scene& scene, const std::string& name = "bed") {
  std::istringstream in(text);
  return ParseTextBed(in, name, scene);
}

std::string Refusal(const std::string& text, const Scene& scene) {
  try {
    Read(text, scene, "bad");
  } catch (const SceneError& e) {
    return e.field() + ": " + e.what();
  }
  return "accepted";
}

void ExpectSameBeads(const dem::ParticleState& a, const dem::ParticleState& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.position[i], b.position[i]) << "bead " << i;
    EXPECT_EQ(a.radius[i], b.radius[i]) << "bead " << i;
  }
}

TEST(BedFormats, ExportedTextAndLammpsDataReadBackToTheSameBits) {
  const Scene scene = SmallCylinder();
  const dem::ParticleState beads = ThreeBeads(scene);
  const ImportedBed text = Read(ExportBed(beads, scene, BedFormat::kText, "three"), scene);
  EXPECT_EQ(text.format, BedFileFormat::kText);
  ExpectSameBeads(text.beads, beads);
  const ImportedBed data = Read(ExportBed(beads, scene, BedFormat::kLammps, "three"), scene);
  EXPECT_EQ(data.format, BedFileFormat::kLammpsData);
  ExpectSameBeads(data.beads, beads);
  EXPECT_NE(data.Describe().find("3 beads (LAMMPS data file)"), std::string::npos)
      << data.Describe();
}

TEST(BedFormats, ALammpsDataFileOfStyleGranularWithImageFlags) {
  const Scene scene = SmallCylinder();
  const ImportedBed bed = Read(
      "LIGGGHTS data file\n\n2 atoms\n1 atom types\n-0.03 0.03 xlo xhi\n-0.03 0.03 ylo yhi\n"
      "0 0.1 zlo zhi\n\nAtoms # granular\n\n1 1 0.004 2500 0 0 0.002 0 0 0\n"
      "2 1 0.004 2500 0.005 0 0.002 0 0 0\n",
      scene);
  ASSERT_EQ(bed.beads.size(), 2u);
  EXPECT_DOUBLE_EQ(bed.beads.radius[1], 0.002);
  EXPECT_DOUBLE_EQ(bed.beads.position[1].x(), 0.005);
  EXPECT_EQ(bed.lines[1], 12);
}

// A LAMMPS data file's own density, and beads of other sizes than the scene's, were replaced
// or taken without a word: now each is named as the bed is read.
TEST(BedFormats, WhereAFileDisagreesWithTheSceneItIsSaid) {
  const Scene scene = SmallCylinder();
  const std::string header =
      "LAMMPS data file\n\n2 atoms\n1 atom types\n-0.03 0.03 xlo xhi\n-0.03 0.03 ylo yhi\n"
      "0 0.1 zlo zhi\n\nAtoms # sphere\n\n";
  EXPECT_TRUE(Read(header + "1 1 0.004 2650 0 0 0.002\n2 1 0.0045 2650 0.005 0 0.00225\n", scene)
                  .warnings.empty());
  const ImportedBed other =
      Read(header + "1 1 0.003 1000 0 0 0.0015\n2 1 0.003 1000 0.005 0 0.0015\n", scene);
  ASSERT_EQ(other.warnings.size(), 2u);
  EXPECT_EQ(other.warnings[0],
            "bed.import: the file gives 2 beads another density (1000 kg/m^3 the first); the run "
            "gives every bead material.density_kg_m3 = 2650 kg/m^3");
  EXPECT_EQ(other.warnings[1],
            "bed.import: the file's bead diameters, 3 to 3 mm, lie outside the scene's "
            "beads.diameter_min_m to diameter_max_m, 4 to 5 mm; the run uses the file's");
}

// A dump of two frames (the beads falling, then at rest): the last is read, its columns by
// name, scaled coordinates from the box, a diameter halved.
TEST(BedFormats, ALammpsDumpGivesItsLastFrame) {
  const Scene scene = SmallCylinder();
  const std::string frame1 =
      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n-0.03 0.03\n"
      "-0.03 0.03\n0 0.1\nITEM: ATOMS id type x y z radius\n1 1 0 0 0.05 0.002\n"
      "2 1 0.005 0 0.06 0.002\n";
  const std::string frame2 =
      "ITEM: TIMESTEP\n1000\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n-0.03 0.03\n"
      "-0.03 0.03\n0 0.1\nITEM: ATOMS id type xs ys zs diameter\n1 1 0.5 0.5 0.02 0.004\n"
      "2 1 0.6 0.5 0.02 0.004\n";
  const ImportedBed bed = Read(frame1 + frame2, scene);
  EXPECT_EQ(bed.format, BedFileFormat::kLammpsDump);
  ASSERT_EQ(bed.beads.size(), 2u);
  EXPECT_NEAR(bed.beads.position[1].x(), 0.006, 1e-15);
  EXPECT_NEAR(bed.beads.position[1].z(), 0.002, 1e-15);
  EXPECT_DOUBLE_EQ(bed.beads.radius[0], 0.002);
  EXPECT_EQ(bed.lines[1], 22);  // the second frame's second atom
}

TEST(BedFormats, UnitsFromAHeaderOrFromTheScene) {
  Scene scene = SmallCylinder();
  const ImportedBed header = Read("id x_mm y_mm z[mm] d[mm]\n7 1 2 2 4\n", scene);
  EXPECT_DOUBLE_EQ(header.beads.position[0].x(), 0.001);
  EXPECT_DOUBLE_EQ(header.beads.radius[0], 0.002);
  scene.bed.import_units = "mm";
  const ImportedBed plain = Read("1 2 2 2\n", scene);
  EXPECT_DOUBLE_EQ(plain.beads.position[0].y(), 0.002);
  EXPECT_DOUBLE_EQ(plain.beads.radius[0], 0.002);
  // Millimetres read as metres: a bead larger than the cylinder, with the hint.
  scene.bed.import_units = "m";
  EXPECT_NE(Refusal("0 0 0.002 0.0000002\n", scene).find("bed.import_units = \"mm\""),
            std::string::npos);
}

TEST(BedFormats, MalformedFilesAreRefusedNamingTheLine) {
  const Scene scene = SmallCylinder();
  EXPECT_NE(Refusal("x y z q\n0 0 0.002 0.002\n", scene)
                .find("bed.import: bad:1: a header names the columns x, y, z and one of r"),
            std::string::npos);
  EXPECT_NE(Refusal("x_ft y z r\n", scene).find("bad:1: column \"x_ft\": unit \"ft\" is none of"),
            std::string::npos);
  EXPECT_NE(Refusal("0 0 0.002 0.002\nx y z r\n", scene)
                .find("bad:2: expected four numbers: x y z radius (a header"),
            std::string::npos);
  EXPECT_NE(Refusal("0 0 0.002 0.002 7\n", scene)
                .find("bad:1: expected 4 numbers: x y z radius; unexpected text \"7\""),
            std::string::npos);
  EXPECT_NE(Refusal("title\n\n1 atoms\n\nAtoms # atomic\n\n1 1 0 0 0.002\n", scene)
                .find("bad:5: atom style \"atomic\": dembuf reads styles sphere and granular"),
            std::string::npos);
  EXPECT_NE(Refusal("title\n\n2 atoms\n\nAtoms # sphere\n\n1 1 0.004 2500 0 0 0.002\n", scene)
                .find("the Atoms section ends after 1 of 2 atoms"),
            std::string::npos);
  EXPECT_NE(Refusal("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS ff ff ff\n"
                    "0 1\n0 1\n0 1\nITEM: ATOMS id x y z\n1 0 0 0.002\n",
                    scene)
                .find("bad:9: the dump's atoms have no radius or diameter column"),
            std::string::npos);
  EXPECT_NE(Refusal("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1e12\n", scene)
                .find("bad:4: the number of atoms must be 1 to"),
            std::string::npos);
  Scene wrong_unit = scene;
  wrong_unit.bed.import_units = "ft";
  EXPECT_NE(Refusal("0 0 0.002 0.002\n", wrong_unit).find("bed.import_units: \"ft\" is none of"),
            std::string::npos);
}

}  // namespace
}  // namespace dembuf
