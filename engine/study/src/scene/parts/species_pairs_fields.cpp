// The scene rows of bead species (parts/species_pairs.h) and of the layers that mix them: the
// second and third species' materials and sizes, the rules of the pairs between species, and
// each layer's thickness and mixture. A row of a species no layer mixes in, or of the layers of
// a bed of one species and one layer, is not in use (SceneField::in_use): the bed keys leave it
// out, so that a bed of one species keeps the key it had before species existed.
#include <deque>
#include <string>

#include "dembuf/study/scene/species.h"
#include "scene/field_row.h"

namespace dembuf {

namespace {

template <int k>
bool SpeciesUsed(const Scene& scene) {
  return SpeciesInBed(scene, k);
}
template <int a, int b>
bool PairUsed(const Scene& scene) {
  return SpeciesInBed(scene, a) && SpeciesInBed(scene, b);
}
bool LayersUsed(const Scene& scene) {
  return MixedBed(scene);
}

// A name or help text made at run time, kept for the table's string_views (which it outlives:
// the rows are made once).
const std::string& Text(std::string text) {
  static std::deque<std::string> texts;
  return texts.emplace_back(std::move(text));
}

// The rows of species slot `index` of Scene::species, named species<index + 2>.
template <int index>
std::vector<SceneField> SpeciesRows() {
  const std::string prefix = "species" + std::to_string(index + 2) + ".";
  const std::string of = " of species " + std::to_string(index + 2);
  constexpr auto used = SpeciesUsed<index + 1>;
  return {
      {.name = Text(prefix + "name"),
       .help = Text("name" + of + " (summaries, frames, bed files)"),
       .shapes = Shapes::kOutput,
       .ref = DEMBUF_FIELD(species[index].name)},
      {.name = Text(prefix + "density_kg_m3"),
       .unit = "kg/m^3",
       .help = Text("density" + of),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].density_kg_m3),
       .min = 0.0,
       .max = 1e5,
       .min_open = true,
       .in_use = used},
      {.name = Text(prefix + "youngs_modulus_Pa"),
       .unit = "Pa",
       .help = Text("Young's modulus E" + of),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].youngs_modulus_Pa),
       .min = 0.0,
       .max = 1e13,
       .min_open = true,
       .in_use = used},
      {.name = Text(prefix + "poisson_ratio"),
       .help = Text("Poisson ratio nu" + of),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].poisson_ratio),
       .min = 0.0,
       .max = 0.5,
       .max_open = true,
       .in_use = used},
      {.name = Text(prefix + "restitution"),
       .help = Text("e of two mean beads" + of + " at material.restitution_ref_speed_m_s"),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].restitution),
       .min = 0.0,
       .max = 1.0,
       .min_open = true,
       .in_use = used},
      {.name = Text(prefix + "friction_bead_bead"),
       .help = Text("mu of two beads" + of),
       .shapes = Shapes::kFrictionBed,
       .ref = DEMBUF_FIELD(species[index].friction_bead_bead),
       .min = 0.0,
       .max = 10.0,
       .in_use = used},
      {.name = Text(prefix + "friction_bead_wall"),
       .help = Text("mu of species " + std::to_string(index + 2) + "'s beads with plate and wall"),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].friction_bead_wall),
       .min = 0.0,
       .max = 10.0,
       .in_use = used},
      {.name = Text(prefix + "diameter_min_m"),
       .unit = "m",
       .help = Text("smallest diameter" + of),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].diameter_min_m),
       .min = 0.0,
       .max = 1.0,
       .min_open = true,
       .in_use = used},
      {.name = Text(prefix + "diameter_max_m"),
       .unit = "m",
       .help = Text("largest diameter" + of),
       .shapes = Shapes::kSourceBed,
       .ref = DEMBUF_FIELD(species[index].diameter_max_m),
       .min = 0.0,
       .max = 1.0,
       .min_open = true,
       .in_use = used},
  };
}

// The rows of layer slot `index` of Scene::layers, named layer<index + 1>; the top layer has no
// thickness of its own.
template <int index>
std::vector<SceneField> LayerRows() {
  const std::string prefix = "layer" + std::to_string(index + 1) + ".";
  const std::string in = " in layer " + std::to_string(index + 1);
  std::vector<SceneField> rows;
  if (index + 1 < kMaxLayers)
    rows.push_back({.name = Text(prefix + "thickness_m"),
                    .unit = "m",
                    .help = Text("thickness of layer " + std::to_string(index + 1) +
                                 "; 0 = it fills the bed up to bed.thickness_m"),
                    .shapes = Shapes::kSourceBed,
                    .ref = DEMBUF_FIELD(layers[index].thickness_m),
                    .min = 0.0,
                    .max = 10.0,
                    .in_use = LayersUsed});
  rows.push_back({.name = Text(prefix + "fraction2"),
                  .help = Text("volume fraction of species 2" + in),
                  .shapes = Shapes::kSourceBed,
                  .ref = DEMBUF_FIELD(layers[index].fraction2),
                  .min = 0.0,
                  .max = 1.0,
                  .in_use = LayersUsed});
  rows.push_back({.name = Text(prefix + "fraction3"),
                  .help = Text("volume fraction of species 3" + in),
                  .shapes = Shapes::kSourceBed,
                  .ref = DEMBUF_FIELD(layers[index].fraction3),
                  .min = 0.0,
                  .max = 1.0,
                  .in_use = LayersUsed});
  return rows;
}

// The rows of the rules of the pair of species a and b (0-based), whose given values are
// the members `restitution` and `friction` of PairRulesSpec.
template <int a, int b, double PairRulesSpec::*restitution, double PairRulesSpec::*friction>
std::vector<SceneField> PairRows() {
  const std::string pair = std::to_string(a + 1) + "_" + std::to_string(b + 1);
  const std::string which = "species " + std::to_string(a + 1) + " on " + std::to_string(b + 1);
  return {
      {.name = Text("pairs.restitution_" + pair),
       .help = Text("e of " + which + "; 0 = the mean of theirs"),
       .shapes = Shapes::kSourceBed,
       .ref = +[](Scene& s) -> double& { return s.pairs.*restitution; },
       .min = 0.0,
       .max = 1.0,
       .in_use = PairUsed<a, b>},
      {.name = Text("pairs.friction_" + pair),
       .help = Text("mu of " + which + "; -1 = the smaller of theirs"),
       .shapes = Shapes::kFrictionBed,
       .ref = +[](Scene& s) -> double& { return s.pairs.*friction; },
       .min = -1.0,
       .max = 10.0,
       .in_use = PairUsed<a, b>},
  };
}

}  // namespace

std::vector<SceneField> SpeciesPairsFields() {
  static_assert(kMaxSpecies == 3 && kMaxLayers == 3, "a template call per slot below");
  static const std::vector<SceneField> rows = [] {
    std::vector<SceneField> all;
    using P = PairRulesSpec;
    for (const auto& part : {SpeciesRows<0>(), SpeciesRows<1>(),
                             PairRows<0, 1, &P::restitution_1_2, &P::friction_1_2>(),
                             PairRows<0, 2, &P::restitution_1_3, &P::friction_1_3>(),
                             PairRows<1, 2, &P::restitution_2_3, &P::friction_2_3>(),
                             LayerRows<0>(), LayerRows<1>(), LayerRows<2>()})
      all.insert(all.end(), part.begin(), part.end());
    return all;
  }();
  return rows;
}

}  // namespace dembuf
