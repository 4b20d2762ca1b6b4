// A scene's bead species and layers as the rest of the study reads them: which species the bed
// mixes in, each one's material in one form whatever field set it (species 1 is material.* and
// beads.*, the others species2.* and species3.*), the rules of the pairs between two of them,
// and the layers' heights. docs/model.md "Species" states the rules.
#pragma once

#include <string>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// The longest name a species may have (material.name, species2.name, ...).
inline constexpr std::size_t kMaxSpeciesName = 40;

/// One species' material and sizes.
struct SpeciesMaterial {
  std::string name;
  double density_kg_m3 = 0.0;
  double youngs_modulus_Pa = 0.0;
  double poisson_ratio = 0.0;
  double restitution = 0.0;
  double friction_bead_bead = 0.0;
  double friction_bead_wall = 0.0;
  double diameter_min_m = 0.0;
  double diameter_max_m = 0.0;
  double MeanDiameter() const { return 0.5 * (diameter_min_m + diameter_max_m); }
  /// pi/6 <d^3> of diameters uniform in [min, max].
  double MeanVolume() const;
  double MeanMass() const;
};

/// Species k (0-based: 0 is material and beads) of a scene, whether the bed mixes it in or not.
SpeciesMaterial SpeciesOf(const Scene& scene, int k);

/// How many layers the bed has: 1, and one more above each layer with a thickness.
int LayerCount(const Scene& scene);

/// How many species the world has: 1 + the highest species a layer mixes in (a bed of one
/// layer of species 1 alone has 1: the world is that of one material).
int SpeciesCount(const Scene& scene);

/// Whether species k (0-based) acts in the scene: mixed into a layer of the bed (an atom type
/// of an imported one), or species 1, the projectile's material, whether the bed has it or not.
bool SpeciesInBed(const Scene& scene, int k);

/// Whether the bed has beads of species k (0-based): mixed into a layer, or an atom type of an
/// imported bed. What the beads' sizes and time step are taken over.
bool HasBeadsOf(const Scene& scene, int k);

/// Whether the bed has more than one species or more than one layer.
bool MixedBed(const Scene& scene);

/// Whether layer `layer` (0-based) mixes more than one species.
bool MixesSpecies(const Scene& scene, int layer);

/// The volume fraction of species k (0-based) in layer `layer` (0-based).
double LayerFraction(const Scene& scene, int layer, int k);

/// The height of the bottom of layer `layer` (0-based): the sum of the thicknesses below it.
double LayerBottom(const Scene& scene, int layer);

/// The smallest and largest diameters of the species in the bed.
double SmallestDiameter(const Scene& scene);
double LargestDiameter(const Scene& scene);

/// The bed's typical bead: the mean bead of the species with the most volume in the bed
/// (species 1 on a tie, and for an imported bed, whose shares are not known before it is
/// read). The rest criterion's m g d and the peak rule's unit of depth.
struct MeanBead {
  double diameter_m = 0.0;
  double mass_kg = 0.0;
};
MeanBead BedMeanBead(const Scene& scene);

/// The pair rules (PairRulesSpec): species a and b's restitution and friction (a == b: the
/// species' own).
double PairRestitution(const Scene& scene, int a, int b);
double PairFriction(const Scene& scene, int a, int b);

/// Checks the layers and species (ranges apart, which the field table checks): the layers'
/// order and thicknesses, their fractions, each species' sizes. Throws SceneError naming the
/// field.
void CheckSpeciesAndLayers(const Scene& scene);

}  // namespace dembuf
