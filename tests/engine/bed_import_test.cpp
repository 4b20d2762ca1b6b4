// Beds from other codes: a bead outside the container is refused with its line (one at
// z = 1e8 m crashed the neighbour list); a settled bed, whose beads rest on each other, on the
// plate and on the wall with their small contact overlaps, is accepted with the overlaps
// reported; larger overlaps are refused naming the worst bead, or separated on request.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>

#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "engine/squeezed_bed.h"
#include "engine/temp_path.h"

namespace dembuf {
namespace {

// A 2.5 cm cylinder importing `text` (one bead per line: x y z radius).
Scene ImportScene(const std::string& text, const std::string& name) {
  const std::string path = test::TempPath(name);
  std::ofstream(path) << text;
  Scene scene;
  scene.cylinder.radius_m = 0.025;
  scene.projectile.diameter_m = 0.01;
  scene.bed.import = path;
  return scene;
}

std::string Refusal(const Scene& scene) {
  try {
    ReadTextBed(scene.bed.import, scene);
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed.import");
    return e.what();
  }
  return "";
}

// A square monolayer of 4 mm beads on the plate, `gap` apart (negative: overlapping), each
// sunk `sink` into the plate: the resting contacts of a bed settled by another code.
std::string Monolayer(double gap, double sink) {
  const double r = 0.002, spacing = 2 * r + gap;
  std::ostringstream out;
  out.precision(17);
  out << "# x y z radius (m)\n";
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j) {
      const double x = spacing * i, y = spacing * j;
      if (std::hypot(x, y) > 0.025 - 2 * r) continue;
      out << x << " " << y << " " << r - sink << " " << r << "\n";
    }
  return out.str();
}

TEST(BedImport, ABeadOutsideTheContainerIsRefusedWithItsLine) {
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 0.002\n0 0 1e8 0.002\n", "far.txt"))
                .find("far.txt:2: bead reaches above the side wall (cylinder.height_m = 0.3 m)"),
            std::string::npos);
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 0.002\n0.1 0 0.01 0.002\n", "out.txt"))
                .find("out.txt:2: bead reaches outside the cylinder"),
            std::string::npos);
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 0.002\n0 0.01 -0.5 0.002\n", "below.txt"))
                .find("below.txt:2: bead reaches below the plate"),
            std::string::npos);
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 0.002\n0 0.01 0.002 0\n", "radius.txt"))
                .find("radius.txt:2: radius 0 m is below 1e-06 m, the smallest bead this model "
                      "covers"),
            std::string::npos);
  // A bead of 1e-12 m segfaulted a run (its neighbour grid had 1e33 cells).
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 0.002\n0 0.01 0.002 1e-12\n", "tiny.txt"))
                .find("tiny.txt:2: radius 1e-12 m is below 1e-06 m"),
            std::string::npos);
  // A file in millimetres read as metres: the refusal named no unit.
  EXPECT_NE(Refusal(ImportScene("0 0 2.1 2.00053\n", "mm.txt"))
                .find("mm.txt:1: radius 2.00053 m must be below half the cylinder's radius; if "
                      "the file is in millimetres, set bed.import_units = \"mm\""),
            std::string::npos);
  EXPECT_NE(Refusal(ImportScene("0 0 0.002 " + std::string(5000, '1') + "\n", "long.txt"))
                .find("long.txt:1: a line longer than 4096 bytes"),
            std::string::npos);
}

// Found by the fuzzer: beads of 2e-21 m make cells so small that a bead 0.4 mm up is in cell
// 1e17, whose hash overflowed a long (undefined behaviour, caught by UBSan in the sanitizer
// suite). Such a file must get an answer, not undefined behaviour.
TEST(BedImport, TinyBeadsFarOutOfTheirCellsAreMeasured) {
  Scene scene;
  scene.cylinder.radius_m = 0.02;
  std::istringstream in("0 0 0.0002 2e-21\n0 0 0.0004 2e-21\n");
  try {
    const ImportedBed bed = ParseTextBed(in, "tiny.txt", scene);
    EXPECT_EQ(bed.pairs.contacts, 0u);
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed.import");
  }
}

TEST(BedImport, ASettledBedsRestingContactsAreAccepted) {
  // 0.3 um into the plate and 0.3 um into each neighbour: a bed as LAMMPS leaves it at rest.
  // These were refused ("reaches below the plate"), so no settled bed could be brought in.
  const Scene scene = ImportScene(Monolayer(-0.3e-6, 0.3e-6), "resting.txt");
  const ImportedBed bed = ReadTextBed(scene.bed.import, scene);
  EXPECT_GT(bed.beads.size(), 80u);
  EXPECT_EQ(bed.plate.contacts, bed.beads.size());
  EXPECT_NEAR(bed.plate.max_ratio, 0.3e-6 / 0.002, 1e-9);
  EXPECT_GT(bed.pairs.contacts, bed.beads.size());
  EXPECT_NEAR(bed.pairs.max_ratio, 0.3e-6 / 0.002, 1e-6);
  EXPECT_EQ(bed.wall.contacts, 0u);
  const std::string report = bed.Describe();
  EXPECT_NE(report.find("resting on the plate: " + std::to_string(bed.beads.size()) +
                        " beads, overlap at most 0.015% of a radius"),
            std::string::npos)
      << report;
  // It comes to rest as it is, and the report reaches the run's summary.
  const World world = BuildWorld(scene);
  EXPECT_EQ(world.beads.size(), bed.beads.size());
  EXPECT_NEAR(world.bed.rest_plate_force_N / world.bed.weight_N, 1.0, 0.01);
  EXPECT_NE(world.bed.note.find("resting on the plate"), std::string::npos) << world.bed.note;
}

TEST(BedImport, LargerOverlapsAreRefusedNamingTheWorstBead) {
  // A bead 5% of its radius into the plate, another 5% into the wall.
  const double r = 0.002;
  std::ostringstream plate, wall;
  plate.precision(17);
  wall.precision(17);
  plate << "0 0 " << r << " " << r << "\n0.01 0 " << 0.95 * r << " " << r << "\n";
  wall << "0 0 " << r << " " << r << "\n" << 0.025 - 0.95 * r << " 0 " << r << " " << r << "\n";
  EXPECT_NE(Refusal(ImportScene(plate.str(), "plate.txt"))
                .find("plate.txt:2: the bead sinks into the plate by 5% of its radius"),
            std::string::npos)
      << Refusal(ImportScene(plate.str(), "plate.txt"));
  EXPECT_NE(Refusal(ImportScene(wall.str(), "wall.txt"))
                .find("wall.txt:2: the bead sinks into the side wall by 5% of its radius"),
            std::string::npos)
      << Refusal(ImportScene(wall.str(), "wall.txt"));
  const std::string pairs = Refusal(ImportScene(Monolayer(-0.0002, 0.0), "pairs.txt"));
  EXPECT_NE(pairs.find("overlap by 10% of the smaller radius"), std::string::npos) << pairs;
  EXPECT_NE(pairs.find("bed.import_overlaps = \"relax\""), std::string::npos) << pairs;
}

TEST(BedImport, ABedSettledByLammpsIsAccepted) {
  // 690 beads of 4 mm poured and settled by LAMMPS's GRANULAR package in a 2.5 cm cylinder
  // (tests/data/lammps/in.settle): they rest on the plate, the wall and each other with
  // overlaps of 0.1 to 0.3 um, and the whole bed was refused for them.
  Scene scene;
  scene.cylinder.radius_m = 0.025;
  scene.projectile.diameter_m = 0.01;
  scene.bed.import = DEMBUF_TEST_DATA_DIR "/lammps_settled_bed.txt";
  const ImportedBed bed = ReadTextBed(scene.bed.import, scene);
  EXPECT_EQ(bed.beads.size(), 690u);
  EXPECT_GT(bed.plate.contacts, 50u);
  EXPECT_GT(bed.wall.contacts, 50u);
  EXPECT_GT(bed.pairs.contacts, 1000u);
  for (const OverlapStats* s : {&bed.plate, &bed.wall, &bed.pairs}) {
    EXPECT_GT(s->max_ratio, 0.0);
    EXPECT_LT(s->max_ratio, 2e-4);  // 0.4 um
  }
  EXPECT_EQ(bed.moved, 0u);
  // At rest as LAMMPS left it: dembuf's own relaxation finds the plate and wall carrying it.
  const World world = BuildWorld(scene);
  EXPECT_NEAR((world.bed.rest_plate_force_N + world.bed.rest_wall_force_z_N) / world.bed.weight_N,
              1.0, 0.01);
}

// The hard case whose relaxation threw beads out (a 5% squeeze: 10% of a radius), separated.
TEST(BedImport, LargerOverlapsAreSeparatedOnRequestWithAReport) {
  Scene scene = ImportScene(test::SqueezedLayers(0.05, 0.025), "squeezed.txt");
  EXPECT_NE(Refusal(scene).find("overlap by 10% of the smaller radius"), std::string::npos);
  SetSceneField(scene, "bed.import_overlaps", "relax");
  const ImportedBed bed = ReadTextBed(scene.bed.import, scene);
  EXPECT_LE(bed.pairs.max_ratio, 0.01);
  EXPECT_LE(bed.plate.max_ratio, 0.01);
  EXPECT_GT(bed.moved, 0u);
  EXPECT_NE(bed.Describe().find("separated: "), std::string::npos) << bed.Describe();
  for (std::size_t i = 0; i < bed.beads.size(); ++i) {
    const dem::Vec3& x = bed.beads.position[i];
    EXPECT_LE(std::hypot(x.x(), x.y()) + bed.beads.radius[i], 0.025 * (1 + 1e-9));
    EXPECT_GE(x.z(), 0.99 * bed.beads.radius[i]);
  }
  const World world = BuildWorld(scene);
  EXPECT_EQ(world.beads.size(), bed.beads.size());
  EXPECT_NEAR(world.bed.rest_plate_force_N / world.bed.weight_N, 1.0, 0.01);
}

// A file of one bead repeated 60,000 times: every pair of the one cell was tried (8 to 10 s
// of the daemon's CPU for each submission). Refused as a pile, before any pair is tried.
TEST(BedImport, OneBeadRepeatedIsRefusedAsAPileBeforeItsPairsAreTried) {
  std::string text;
  for (int k = 0; k < 60000; ++k) text += "0 0 0.005 0.002\n";
  const std::string why = Refusal(ImportScene(text, "pile.txt"));
  EXPECT_NE(why.find("pile.txt: 60000 beads lie in one place (lines 1, 2, 3, 4, 5, ...)"),
            std::string::npos)
      << why;
  Scene relax = ImportScene(text, "pile-relax.txt");
  relax.bed.import_overlaps = "relax";
  EXPECT_NE(Refusal(relax).find("beads lie in one place"), std::string::npos);
}

// The pairs are sought by size class: a small bead touching a large one of another class is
// met, as are pairs within a class; beads of every size class far apart are not.
TEST(BedImport, PairsOfBeadsOfVeryDifferentSizesAreFound) {
  // A 10 mm bead resting on the plate, and a 0.1 mm bead sunk 5% of its radius into its side.
  const double big = 0.005, small = 0.0001;
  std::ostringstream text;
  text.precision(17);
  text << "0 0 " << big << " " << big << "\n";
  text << big + small * 0.95 << " 0 " << big << " " << small << "\n";
  text << "0.015 0 0.01 " << small << "\n";  // alone
  const std::string why = Refusal(ImportScene(text.str(), "sizes.txt"));
  EXPECT_NE(why.find("the beads of lines 1 and 2 overlap by 5%"), std::string::npos) << why;
}

// A sweep of many runs on one large sent file is estimated run by run (and again as each job
// queues and runs): the file is measured once for its content, not once a run. Shown by
// giving the same digest with other bytes: the size of the first is what comes back.
TEST(BedImport, AnImportIsMeasuredOnceForItsContent) {
  Scene scene = ImportScene("", "measured.txt");
  scene.bed.import_bytes = std::make_shared<const std::string>(Monolayer(1e-4, 0.0));
  scene.bed.import_sha256 = std::string(64, 'a');
  const ImportedBedSize first = MeasureImportedBed(scene);
  EXPECT_GT(first.beads, 50.0);
  EXPECT_DOUBLE_EQ(first.max_radius_m, 0.002);
  EXPECT_DOUBLE_EQ(first.top_m, 0.004);
  scene.bed.import_bytes = std::make_shared<const std::string>("0 0 0.001 0.001\n");
  EXPECT_EQ(MeasureImportedBed(scene).beads, first.beads);
  // Another digest, or the same content checked against another container, is measured anew.
  scene.bed.import_sha256 = std::string(64, 'b');
  EXPECT_EQ(MeasureImportedBed(scene).beads, 1.0);
  scene.bed.import_sha256 = std::string(64, 'a');
  scene.cylinder.radius_m = 0.03;
  EXPECT_EQ(MeasureImportedBed(scene).beads, 1.0);
  // Without a digest given, it is the content's own.
  scene.bed.import_sha256.clear();
  EXPECT_EQ(ImportContentSha256(scene),
            "e2ee763d23d5c80341442fe56dcffe442aa3971ed6437937aff344fcbd949b6d");
}

}  // namespace
}  // namespace dembuf
