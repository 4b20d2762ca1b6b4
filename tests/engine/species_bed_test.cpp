// Beds of several species: a mixture's fractions, a layered bed's interface, the bed file that
// keeps both, the checks of a scene's species and layers, and bed files whose atom types are
// species, in and out.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <set>
#include <sstream>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/scene/species.h"

#include "engine/small_bed.h"
#include "engine/temp_path.h"

namespace dembuf {
namespace {

using test::SmallBedScene;

double Volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

// The share of the beads' volume that is of species `kind`.
double VolumeShare(const dem::ParticleState& beads, dem::Species kind) {
  double of = 0.0, all = 0.0;
  for (std::size_t i = 0; i < beads.size(); ++i) {
    all += Volume(beads.radius[i]);
    if (beads.species[i] == kind) of += Volume(beads.radius[i]);
  }
  return of / all;
}

// A mixture of 30% steel shot by volume in the small bed, poured to H (not cut from a deeper
// source, where the steel sinks as the bed settles).
TEST(SpeciesBed, AMixtureHasTheFractionAskedAndTheSpeciesDensities) {
  Scene scene = SmallBedScene();
  scene.layers[0].fraction2 = 0.3;
  BedCache cache;
  const PreparedBed source = GetSourceBed(scene, cache);
  // Inserted to within a bead of the fraction; settling moves no bead from one to the other.
  EXPECT_NEAR(VolumeShare(source.beads, 1), 0.3, 0.01);
  // Each H has a source of its own.
  Scene thicker = scene;
  thicker.bed.thickness_m = 0.011;
  EXPECT_NE(BedSourceHash(thicker), BedSourceHash(scene));
  const PreparedBed bed = GetBed(scene, cache);
  EXPECT_EQ(bed.stage, "cut");
  // The cut takes the top off a bed poured for H: the mixture's within the scatter of the few
  // hundred beads of the small bed.
  EXPECT_NEAR(VolumeShare(bed.beads, 1), 0.3, 0.05);
  for (std::size_t i = 0; i < bed.beads.size(); ++i) {
    const double rho = bed.beads.species[i] == 1 ? 7850.0 : 2650.0;
    ASSERT_NEAR(bed.beads.mass[i], rho * Volume(bed.beads.radius[i]), 1e-9 * bed.beads.mass[i]);
  }
  EXPECT_NO_THROW(CheckPreparedBed(bed, scene));
  // At rest, every bead on the plate or another: the plate and wall carry the bed's weight.
  EXPECT_NEAR((bed.plate_force_N + bed.wall_force_z_N) / bed.weight_N, 1.0, 0.01);
  const std::vector<LayerSummary> layers = MeasureLayers(bed.beads, scene);
  ASSERT_EQ(layers.size(), 1u);
  EXPECT_NEAR(layers[0].top_m, scene.bed.thickness_m, 0.5 * scene.beads.diameter_max_m);
  EXPECT_GT(layers[0].beads[0], 2 * layers[0].beads[1]);  // 70% glass by volume
  EXPECT_GT(layers[0].beads[1], 20u);
}

// Steel shot under glass beads: the steel layer poured, settled and cut at 5 mm, then the glass
// poured on it, settled, and the whole cut to H. The interface lies within a bead diameter of
// where it was asked; each layer holds its own species alone.
TEST(SpeciesBed, ALayeredBedHasItsInterfaceWithinABeadDiameterOfWhereItWasAsked) {
  Scene scene = SmallBedScene();
  scene.bed.thickness_m = 0.012;
  scene.layers[0] = {.thickness_m = 0.005, .fraction2 = 1.0};
  ASSERT_EQ(LayerCount(scene), 2);
  ASSERT_NO_THROW(ValidateScene(scene));
  std::set<std::string> stages;
  BedRequest request;
  request.on_progress = [&](const BedProgress& p) { stages.insert(p.stage); };
  BedCache cache;
  const PreparedBed bed = GetBed(scene, cache, request);
  EXPECT_TRUE(stages.count("settling layer 1") && stages.count("settling layer 2"));
  const std::vector<LayerSummary> layers = MeasureLayers(bed.beads, scene);
  ASSERT_EQ(layers.size(), 2u);
  const double d = scene.beads.diameter_max_m;
  EXPECT_NEAR(layers[0].top_m, 0.005, d) << "the interface";
  EXPECT_NEAR(layers[1].top_m, scene.bed.thickness_m, 0.5 * d) << "the surface";
  EXPECT_EQ(layers[0].beads[0], 0u);   // no glass in the steel layer
  EXPECT_EQ(layers[1].beads[1], 0u);   // no steel in the glass
  EXPECT_GT(layers[0].beads[1], 30u);  // a 2 cm cylinder: some 50 beads a layer of 5 mm
  EXPECT_GT(layers[1].beads[0], 50u);
  // Each layer about as dense as the bed (two thin layers in a narrow cylinder: loose).
  for (const LayerSummary& layer : layers)
    EXPECT_NEAR(layer.solid_fraction, bed.solid_fraction, 0.1);
  EXPECT_NO_THROW(CheckPreparedBed(bed, scene));
  // The bed file keeps each bead's species and layer, and its bytes name them.
  const PreparedBed back = ParseBed(SerializeBed(bed), "layered.bed");
  EXPECT_EQ(back.beads.species, bed.beads.species);
  EXPECT_EQ(back.beads.layer, bed.beads.layer);
  // An H the lower layers leave no room under is refused, naming the layer.
  Scene thin = scene;
  thin.bed.thickness_m = 0.006;
  try {
    ValidateScene(thin);
    ADD_FAILURE() << "a top layer thinner than a bead was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "layer1.thickness_m");
  }
}

// A bed of steel shot alone: species 1 has no bead in it, so its sizes and material shape
// neither the step nor the rest criterion: the same bed whatever they are.
TEST(SpeciesBed, ASpeciesWithoutBeadsShapesNothingOfTheBed) {
  Scene steel = SmallBedScene();
  steel.layers[0].fraction2 = 1.0;
  Scene odd = steel;
  odd.beads.diameter_min_m = 4e-4;  // species 1: half-millimetre beads, none in the bed
  odd.beads.diameter_max_m = 5e-4;
  EXPECT_EQ(SmallestDiameter(odd), steel.species[0].diameter_min_m);
  EXPECT_EQ(BedMeanBead(odd).mass_kg, BedMeanBead(steel).mass_kg);
  BedCache cache;
  const PreparedBed a = GetBed(steel, cache), b = GetBed(odd, cache);
  ASSERT_EQ(a.beads.size(), b.beads.size());
  EXPECT_EQ(0, std::memcmp(a.beads.position.data(), b.beads.position.data(),
                           a.beads.size() * sizeof(dem::Vec3)));
  EXPECT_EQ(a.settle_steps, b.settle_steps);
  for (const dem::Species k : a.beads.species) ASSERT_EQ(k, 1);
}

// A second species nearly three times the size of the first, mixed: local settling holds the beads
// around a moving one out to the largest bead's reach, so the settled bed has no overlap past a
// resting contact's.
TEST(SpeciesBed, LargerBeadsOfASecondSpeciesSettleWithoutOverlaps) {
  Scene scene = SmallBedScene();
  scene.cylinder.radius_m = 0.04;
  scene.bed.thickness_m = 0.025;
  scene.layers[0].fraction2 = 0.5;
  scene.species[0] = {.name = "large",
                      .density_kg_m3 = 2650.0,
                      .youngs_modulus_Pa = 5e9,
                      .poisson_ratio = 0.22,
                      .diameter_min_m = 0.012,
                      .diameter_max_m = 0.013};
  ASSERT_TRUE(scene.bed.local_settling);
  BedCache cache;
  const PreparedBed bed = GetBed(scene, cache);
  dem::Simulation sim(BuildWorld(scene, &cache).params, bed.beads, std::nullopt, bed.history);
  sim.RefreshForces();
  EXPECT_LT(sim.observables().max_overlap_ratio, kMaxRestingOverlap);
  EXPECT_NO_THROW(CheckPreparedBed(bed, scene));
  std::size_t large = 0;
  for (const dem::Species k : bed.beads.species) large += k == 1;
  EXPECT_GT(large, 5u);
}

// A bed file's header holds a note and warnings line by line: a line break in one cannot make
// a header key of its own (a forged packing, say).
TEST(SpeciesBed, ALineBreakInANoteStaysInTheNote) {
  PreparedBed bed;
  bed.beads.Add(dem::Vec3(0, 0, 0.002), 0.002, 2650.0);
  bed.solid_fraction = 0.5;
  bed.note = "3 beads\nsolid_fraction=0.99\ndata";
  bed.warnings = {"one\nplate_force_N=12345"};
  const PreparedBed back = ParseBed(SerializeBed(bed), "note.bed");
  EXPECT_EQ(back.solid_fraction, 0.5);
  EXPECT_EQ(back.plate_force_N, 0.0);
  EXPECT_EQ(back.beads.size(), 1u);
}

// A bed of one species is written as it always was: no species or layer block, the same bytes.
TEST(SpeciesBed, ABedOfOneSpeciesIsWrittenWithoutSpecies) {
  PreparedBed bed;
  bed.beads.Add(dem::Vec3(0, 0, 0.002), 0.002, 2650.0);
  const std::string bytes = SerializeBed(bed);
  EXPECT_EQ(bytes.find("species="), std::string::npos);
  EXPECT_EQ(bytes.find("layers="), std::string::npos);
  bed.beads.species[0] = 1;
  const std::string mixed = SerializeBed(bed);
  EXPECT_NE(mixed.find("species=per bead"), std::string::npos);
  EXPECT_EQ(ParseBed(mixed, "mixed.bed").beads.species[0], 1);
  // A damaged species byte is seen.
  std::string damaged = mixed;
  damaged[damaged.size() - 9] ^= 1;
  EXPECT_THROW(ParseBed(damaged, "damaged.bed"), std::runtime_error);
}

// The checks of a scene's species and layers, each naming its field.
struct BadSpecies {
  const char* name;
  void (*change)(Scene&);
  const char* field;
};

class SpeciesScene : public testing::TestWithParam<BadSpecies> {};

TEST_P(SpeciesScene, IsRefusedNamingTheField) {
  Scene scene = SmallBedScene();
  GetParam().change(scene);
  try {
    ValidateScene(scene);
    ADD_FAILURE() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), GetParam().field) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Bad, SpeciesScene,
    testing::Values(
        BadSpecies{"fractions_over_one",
                   [](Scene& s) {
                     s.layers[0].fraction2 = 0.7;
                     s.layers[0].fraction3 = 0.4;
                   },
                   "layer1.fraction3"},
        BadSpecies{"a_layer_above_a_full_one", [](Scene& s) { s.layers[1].fraction2 = 0.5; },
                   "layer2.fraction2"},
        BadSpecies{"a_layer_thinner_than_a_bead", [](Scene& s) { s.layers[0].thickness_m = 0.002; },
                   "layer1.thickness_m"},
        BadSpecies{"sizes_the_wrong_way", [](Scene& s) { s.species[0].diameter_min_m = 0.006; },
                   "species2.diameter_min_m"},
        BadSpecies{"two_species_of_one_name",
                   [](Scene& s) {
                     s.layers[0].fraction2 = 0.5;
                     s.species[0].name = s.material.name;
                   },
                   "species2.name"},
        BadSpecies{"a_name_with_a_line_break",
                   [](Scene& s) { s.species[0].name = "steel\nsolid_fraction=0.99"; },
                   "species2.name"},
        BadSpecies{"an_empty_name", [](Scene& s) { s.material.name = ""; }, "material.name"},
        BadSpecies{"a_friction_neither_rule_nor_value",
                   [](Scene& s) { s.pairs.friction_1_2 = -0.5; }, "pairs.friction_1_2"},
        BadSpecies{"layers_with_a_bed_file",
                   [](Scene& s) {
                     s.bed.import = "bed.txt";
                     s.bed.import_bytes = std::make_shared<const std::string>("0 0 0.002 0.002\n");
                     s.layers[0].fraction2 = 0.5;
                   },
                   "layer1.fraction2"}),
    [](const testing::TestParamInfo<BadSpecies>& info) { return info.param.name; });

// The friction stage runs for the pairs the bed has: a bed of steel alone, prepared at its own
// friction, has none, whatever species 1's friction (the projectile's) is.
TEST(SpeciesScene, TheFrictionStageIsForThePairsOfTheBed) {
  Scene steel = SmallBedScene();
  steel.layers[0].fraction2 = 1.0;
  steel.material.friction_bead_bead = 0.3;
  steel.species[0].friction_bead_bead = steel.bed.prep_friction;
  EXPECT_FALSE(NeedsFrictionStage(steel));
  EXPECT_EQ(BedStagesOf(steel).size(), 2u);
  steel.species[0].friction_bead_bead = 0.3;
  EXPECT_TRUE(NeedsFrictionStage(steel));
}

// Fractions of species 2 and 3 that sum to 1 leave species 1 none, whatever the rounding.
TEST(SpeciesScene, FractionsSummingToOneLeaveSpecies1None) {
  Scene scene;
  scene.layers[0].fraction2 = 0.7;
  scene.layers[0].fraction3 = 0.3;
  EXPECT_EQ(LayerFraction(scene, 0, 0), 0.0);
  EXPECT_FALSE(HasBeadsOf(scene, 0));
  EXPECT_TRUE(SpeciesInBed(scene, 0));  // the projectile's material still
}

// Fields by their dotted names, as a scene file and --set give them.
TEST(SpeciesScene, SpeciesAndLayersAreFieldsOfTheTable) {
  Scene scene;
  SetSceneField(scene, "species2.density_kg_m3", "7800");
  SetSceneField(scene, "layer1.thickness_m", "0.01");
  SetSceneField(scene, "layer1.fraction2", "1");
  SetSceneField(scene, "species3.name", "rubber");
  EXPECT_EQ(scene.species[0].density_kg_m3, 7800.0);
  EXPECT_EQ(scene.species[1].name, "rubber");
  EXPECT_EQ(scene.layers[0].thickness_m, 0.01);
  EXPECT_EQ(SpeciesCount(scene), 2);
  EXPECT_EQ(LayerCount(scene), 2);
  const Scene read = LoadSceneText(
      "[species2]\nname = \"steel\"\n[layer1]\nthickness_m = 0.01\nfraction2 = 1.0\n"
      "[layer2]\nfraction3 = 0.25\n[pairs]\nrestitution_1_2 = 0.6\n",
      "a scene");
  EXPECT_EQ(read.layers[1].fraction3, 0.25);
  EXPECT_EQ(SpeciesCount(read), 3);
  EXPECT_EQ(PairRestitution(read, 1, 0), 0.6);
  try {
    SetSceneField(scene, "layer2.fraction2", "1.5");
    ADD_FAILURE() << "a fraction above 1 was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "layer2.fraction2");
    EXPECT_NE(std::string(e.what()).find("<= 1"), std::string::npos) << e.what();
  }
}

// A LAMMPS data file of two atom types read as two species (bed.import_types = 2), and the
// export of a bed of species written with its species as atom types and read back the same.
TEST(SpeciesBed, AtomTypesAreSpeciesInAndOut) {
  Scene scene = SmallBedScene();
  scene.bed.import = "two-types.data";
  scene.bed.import_types = 2;
  const std::string data =
      "LAMMPS data file\n\n3 atoms\n2 atom types\n-0.03 0.03 xlo xhi\n-0.03 0.03 ylo yhi\n"
      "0 0.1 zlo zhi\n\nAtoms # sphere\n\n"
      "1 1 0.0044 2650 0 0 0.0022\n2 2 0.0044 7850 0.005 0 0.0022\n"
      "3 2 0.0044 7850 -0.005 0 0.0022\n";
  std::istringstream in(data);
  const ImportedBed bed = ParseTextBed(in, "two-types.data", scene);
  ASSERT_EQ(bed.beads.size(), 3u);
  EXPECT_EQ(bed.beads.species, (std::vector<dem::Species>{0, 1, 1}));
  EXPECT_NEAR(bed.beads.mass[1], 7850.0 * Volume(0.0022), 1e-12);
  EXPECT_NE(bed.Describe().find("type 2 species 2 (2 beads)"), std::string::npos) << bed.Describe();
  EXPECT_TRUE(bed.warnings.empty());
  // A type the scene does not have is refused, naming its line.
  Scene one_type = scene;
  one_type.bed.import_types = 1;  // every type species 1, said in a warning
  std::istringstream again(data);
  const ImportedBed all_one = ParseTextBed(again, "two-types.data", one_type);
  EXPECT_EQ(all_one.beads.species, (std::vector<dem::Species>{0, 0, 0}));
  ASSERT_FALSE(all_one.warnings.empty());
  EXPECT_NE(all_one.warnings[0].find("bed.import_types = 1"), std::string::npos);
  std::istringstream three(
      "LAMMPS data file\n\n1 atoms\n3 atom types\n\nAtoms # sphere\n\n1 3 0.0044 2650 0 0 "
      "0.0022\n");
  try {
    ParseTextBed(three, "three.data", scene);
    ADD_FAILURE() << "type 3 of a scene of 2 was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed.import");
    EXPECT_NE(std::string(e.what()).find("three.data:8: atom type 3 is none of 1 to 2"),
              std::string::npos)
        << e.what();
  }
  // A LAMMPS dump's type column, and a text file's, are atom types too.
  std::istringstream dump(
      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n-0.03 0.03\n"
      "-0.03 0.03\n0 0.1\nITEM: ATOMS id type x y z radius\n1 2 0 0 0.0022 0.0022\n"
      "2 1 0.005 0 0.0022 0.0022\n");
  EXPECT_EQ(ParseTextBed(dump, "bed.dump", scene).beads.species, (std::vector<dem::Species>{1, 0}));
  std::istringstream text("x_mm y_mm z_mm d_mm species\n0 0 2.2 4.4 2\n5 0 2.2 4.4 1\n");
  EXPECT_EQ(ParseTextBed(text, "bed.txt", scene).beads.species, (std::vector<dem::Species>{1, 0}));
  // Out and back: the LAMMPS data and the text export keep the species.
  Scene mixed = SmallBedScene();
  mixed.layers[0].fraction2 = 0.5;
  for (const BedFormat format : {BedFormat::kLammps, BedFormat::kText}) {
    const std::string exported = ExportBed(bed.beads, mixed, format, "mixed", std::nullopt);
    std::istringstream back_in(exported);
    const ImportedBed back = ParseTextBed(back_in, "exported", scene);
    EXPECT_EQ(back.beads.species, bed.beads.species) << exported;
  }
  EXPECT_NE(ExportBed(bed.beads, mixed, BedFormat::kLammps, "mixed", std::nullopt)
                .find("atom types 1 beads, 2 steel"),
            std::string::npos);
}

}  // namespace
}  // namespace dembuf
