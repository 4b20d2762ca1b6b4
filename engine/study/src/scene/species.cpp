#include "dembuf/study/scene/species.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/text/number_text.h"
#include "dembuf/study/text/text_limits.h"

namespace dembuf {

namespace {

std::string Number(double v) {
  return NumberText(v, 6);
}

// The name of a layer's field, "layer2.fraction3".
std::string LayerField(int layer, const char* key) {
  return "layer" + std::to_string(layer + 1) + "." + key;
}

}  // namespace

double SpeciesMaterial::MeanVolume() const {
  const double lo = diameter_min_m, hi = diameter_max_m;
  const double mean_d3 =
      hi > lo ? (std::pow(hi, 4) - std::pow(lo, 4)) / (4.0 * (hi - lo)) : lo * lo * lo;
  return std::numbers::pi / 6.0 * mean_d3;
}

double SpeciesMaterial::MeanMass() const {
  const double d = MeanDiameter();
  return density_kg_m3 * std::numbers::pi / 6.0 * d * d * d;
}

SpeciesMaterial SpeciesOf(const Scene& scene, int k) {
  if (k == 0) {
    const MaterialSpec& m = scene.material;
    return {m.name,
            m.density_kg_m3,
            m.youngs_modulus_Pa,
            m.poisson_ratio,
            m.restitution,
            m.friction_bead_bead,
            m.friction_bead_wall,
            scene.beads.diameter_min_m,
            scene.beads.diameter_max_m};
  }
  const SpeciesSpec& s = scene.species.at(static_cast<std::size_t>(k - 1));
  return {s.name,          s.density_kg_m3,      s.youngs_modulus_Pa,  s.poisson_ratio,
          s.restitution,   s.friction_bead_bead, s.friction_bead_wall, s.diameter_min_m,
          s.diameter_max_m};
}

int LayerCount(const Scene& scene) {
  int count = 1;
  while (count < kMaxLayers && scene.layers[count - 1].thickness_m > 0.0) ++count;
  return count;
}

double LayerFraction(const Scene& scene, int layer, int k) {
  const LayerSpec& l = scene.layers.at(static_cast<std::size_t>(layer));
  if (k == 1) return l.fraction2;
  if (k == 2) return l.fraction3;
  // Species 1 takes the rest; a rest of rounding (0.7 + 0.3 leaves 5.6e-17) is none.
  const double rest = 1.0 - l.fraction2 - l.fraction3;
  return rest > 1e-12 ? rest : 0.0;
}

bool MixesSpecies(const Scene& scene, int layer) {
  int present = 0;
  for (int k = 0; k < kMaxSpecies; ++k) present += LayerFraction(scene, layer, k) > 0.0;
  return present > 1;
}

bool SpeciesInBed(const Scene& scene, int k) {
  if (k == 0) return true;  // the projectile's material, whether the bed has it or not
  // An imported bed's species are its file's atom types; the layers shape prepared beds.
  if (!scene.bed.import.empty()) return k < scene.bed.import_types;
  for (int layer = 0; layer < LayerCount(scene); ++layer)
    if (LayerFraction(scene, layer, k) > 0.0) return true;
  return false;
}

bool HasBeadsOf(const Scene& scene, int k) {
  if (k > 0 || !scene.bed.import.empty()) return SpeciesInBed(scene, k);
  for (int layer = 0; layer < LayerCount(scene); ++layer)
    if (LayerFraction(scene, layer, 0) > 0.0) return true;
  return false;
}

int SpeciesCount(const Scene& scene) {
  int count = 1;
  for (int k = 1; k < kMaxSpecies; ++k)
    if (SpeciesInBed(scene, k)) count = k + 1;
  return count;
}

bool MixedBed(const Scene& scene) {
  return SpeciesCount(scene) > 1 || LayerCount(scene) > 1;
}

double LayerBottom(const Scene& scene, int layer) {
  double bottom = 0.0;
  for (int below = 0; below < layer; ++below) bottom += scene.layers[below].thickness_m;
  return bottom;
}

double SmallestDiameter(const Scene& scene) {
  double d = HUGE_VAL;
  for (int k = 0; k < SpeciesCount(scene); ++k)
    if (HasBeadsOf(scene, k)) d = std::min(d, SpeciesOf(scene, k).diameter_min_m);
  return d;
}

double LargestDiameter(const Scene& scene) {
  double d = 0.0;
  for (int k = 0; k < SpeciesCount(scene); ++k)
    if (HasBeadsOf(scene, k)) d = std::max(d, SpeciesOf(scene, k).diameter_max_m);
  return d;
}

MeanBead BedMeanBead(const Scene& scene) {
  int main = 0;
  if (scene.bed.import.empty() && MixedBed(scene)) {
    const int layers = LayerCount(scene);
    double largest = -1.0;
    for (int k = 0; k < SpeciesCount(scene); ++k) {
      double volume = 0.0;  // per unit area
      for (int layer = 0; layer < layers; ++layer) {
        const double thickness =
            layer + 1 < layers ? scene.layers[layer].thickness_m
                               : std::max(scene.bed.thickness_m - LayerBottom(scene, layer), 1e-3);
        volume += thickness * LayerFraction(scene, layer, k);
      }
      if (volume > largest) {
        largest = volume;
        main = k;
      }
    }
  }
  if (main == 0) return {scene.beads.MeanDiameter(), scene.MeanBeadMass()};
  const SpeciesMaterial m = SpeciesOf(scene, main);
  return {m.MeanDiameter(), m.MeanMass()};
}

namespace {

// The given value of pair (a, b) of a = b's rule table, a < b.
double GivenForPair(const double (&given)[3], int a, int b) {
  const int lo = std::min(a, b), hi = std::max(a, b);
  return given[lo == 0 ? hi - 1 : 2];  // (1,2), (1,3), (2,3)
}

}  // namespace

double PairRestitution(const Scene& scene, int a, int b) {
  if (a == b) return SpeciesOf(scene, a).restitution;
  const PairRulesSpec& p = scene.pairs;
  const double given[3] = {p.restitution_1_2, p.restitution_1_3, p.restitution_2_3};
  const double e = GivenForPair(given, a, b);
  // The rule: the mean of the two species' restitutions (Yade's MatchMaker "avg").
  return e > 0.0 ? e : 0.5 * (SpeciesOf(scene, a).restitution + SpeciesOf(scene, b).restitution);
}

double PairFriction(const Scene& scene, int a, int b) {
  if (a == b) return SpeciesOf(scene, a).friction_bead_bead;
  const PairRulesSpec& p = scene.pairs;
  const double given[3] = {p.friction_1_2, p.friction_1_3, p.friction_2_3};
  const double mu = GivenForPair(given, a, b);
  // The rule: the smaller of the two (Yade's FrictPhys: the smaller friction angle).
  return mu >= 0.0 ? mu
                   : std::min(SpeciesOf(scene, a).friction_bead_bead,
                              SpeciesOf(scene, b).friction_bead_bead);
}

void CheckSpeciesAndLayers(const Scene& scene) {
  const int layers = LayerCount(scene);
  // The layers above the last (thickness 0) are not in the bed: a value there is a mistake.
  for (int layer = layers; layer < kMaxLayers; ++layer) {
    const LayerSpec& l = scene.layers[layer];
    for (const auto& [key, value] : {std::pair{"thickness_m", l.thickness_m},
                                     {"fraction2", l.fraction2},
                                     {"fraction3", l.fraction3}})
      if (value != 0.0)
        throw SceneError(LayerField(layer, key),
                         Number(value) + " for a layer the bed does not have: layer " +
                             std::to_string(layer + 1) + " lies above layer " +
                             std::to_string(layer) + ", which has no thickness (layer" +
                             std::to_string(layer) + ".thickness_m = 0 fills the bed)");
  }
  for (int layer = 0; layer < layers; ++layer) {
    const LayerSpec& l = scene.layers[layer];
    if (l.fraction2 + l.fraction3 > 1.0 + 1e-12)
      throw SceneError(LayerField(layer, "fraction3"),
                       Number(l.fraction3) + " with " + LayerField(layer, "fraction2") + " = " +
                           Number(l.fraction2) + ": the fractions of species 2 and 3 sum to " +
                           Number(l.fraction2 + l.fraction3) + "; at most 1 (species 1 takes " +
                           "the rest)");
  }
  const PairRulesSpec& p = scene.pairs;
  for (const auto& [field, mu] : {std::pair{"pairs.friction_1_2", p.friction_1_2},
                                  {"pairs.friction_1_3", p.friction_1_3},
                                  {"pairs.friction_2_3", p.friction_2_3}})
    if (mu < 0.0 && mu != -1.0)
      throw SceneError(field, Number(mu) +
                                  ": a friction coefficient >= 0, or -1 for the rule "
                                  "(the smaller of the two species')");
  // The species are told apart by name in summaries, JSON keys and bed files' titles: a name
  // is a word of a few plain characters (an allow-list: no line break or quote reaches a file).
  for (int k = 0; k < kMaxSpecies; ++k) {
    const std::string field =
        k == 0 ? "material.name" : "species" + std::to_string(k + 1) + ".name";
    const std::string name = SpeciesOf(scene, k).name;
    const auto bad = std::find_if_not(name.begin(), name.end(), [](unsigned char c) {
      return std::isalnum(c) || c == ' ' || c == '_' || c == '.' || c == '+' || c == '-';
    });
    if (name.empty() || name.size() > kMaxSpeciesName || bad != name.end())
      throw SceneError(field, "\"" + PrintableText(name) + "\": a species' name is 1 to " +
                                  std::to_string(kMaxSpeciesName) +
                                  " letters, digits, spaces and _ . + -");
  }
  for (int k = 1; k < SpeciesCount(scene); ++k) {
    const std::string field = "species" + std::to_string(k + 1) + ".name";
    const std::string name = SpeciesOf(scene, k).name;
    if (!SpeciesInBed(scene, k)) continue;
    for (int other = 0; other < k; ++other)
      if (SpeciesInBed(scene, other) && SpeciesOf(scene, other).name == name)
        throw SceneError(field, "\"" + name + "\" is the name of species " +
                                    std::to_string(other + 1) + " too; the species' names differ");
  }
  for (int k = 1; k < kMaxSpecies; ++k) {
    const SpeciesMaterial m = SpeciesOf(scene, k);
    const std::string prefix = "species" + std::to_string(k + 1) + ".";
    if (m.diameter_min_m > m.diameter_max_m)
      throw SceneError(prefix + "diameter_min_m",
                       Number(m.diameter_min_m) + " exceeds " + prefix +
                           "diameter_max_m = " + Number(m.diameter_max_m));
    if (SpeciesInBed(scene, k) && m.diameter_max_m >= scene.cylinder.radius_m)
      throw SceneError(prefix + "diameter_max_m", Number(m.diameter_max_m) +
                                                      " must be smaller than cylinder.radius_m = " +
                                                      Number(scene.cylinder.radius_m));
  }
  if (!scene.bed.import.empty())
    for (int layer = 0; layer < layers; ++layer)
      for (const auto& [key, value] : {std::pair{"thickness_m", scene.layers[layer].thickness_m},
                                       {"fraction2", scene.layers[layer].fraction2},
                                       {"fraction3", scene.layers[layer].fraction3}})
        if (value != 0.0)
          throw SceneError(LayerField(layer, key),
                           Number(value) +
                               " with bed.import: layers shape a prepared bed; an "
                               "imported bed's species are its atom types "
                               "(bed.import_types)");
  if (layers > 1 && scene.bed.thickness_m > 0.0 && scene.bed.import.empty()) {
    const double lower = LayerBottom(scene, layers - 1), d = LargestDiameter(scene);
    for (int layer = 0; layer + 1 < layers; ++layer)
      if (scene.layers[layer].thickness_m < d)
        throw SceneError(LayerField(layer, "thickness_m"),
                         Number(scene.layers[layer].thickness_m) +
                             " m is thinner than the largest bead (" + Number(d) +
                             " m); a layer is at least one bead diameter thick");
    if (lower + d > scene.bed.thickness_m)
      throw SceneError(LayerField(layers - 2, "thickness_m"),
                       "the lower layers reach " + Number(lower) +
                           " m, which leaves the top layer less than a bead diameter (" +
                           Number(d) +
                           " m) below bed.thickness_m = " + Number(scene.bed.thickness_m));
  }
}

}  // namespace dembuf
