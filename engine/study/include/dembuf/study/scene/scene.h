// A scene: everything that defines one impact simulation, as plain data in SI units.
//
// Defaults are the paper's Table 1 (see docs/model.md section 3). Choices the paper leaves open are
// marked [choice] and documented in docs/model.md. Every field has a dotted name (for scene files,
// `--set` overrides and the service API) defined once, in scene_fields.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace dembuf {

/// Rigid cylinder with a flat bottom plate at z = 0; its axis is the z axis.
struct CylinderSpec {
  double radius_m = 0.095;  ///< inner radius (paper: inner diameter 19 cm)
  double height_m = 0.30;   ///< H2; the side wall acts on bodies with 0 <= z <= height
};

/// Bead material and contact parameters (paper Table 1): the bed's first species.
struct MaterialSpec {
  std::string name = "beads";  ///< the species' name (in summaries, frames and bed files)
  double density_kg_m3 = 2650.0;
  double youngs_modulus_Pa = 5.0e9;
  double poisson_ratio = 0.22;
  double restitution = 0.80;               ///< e of two mean beads at restitution_ref_speed
  double restitution_ref_speed_m_s = 1.0;  ///< [choice] calibration speed v_ref
  double friction_bead_bead = 0.50;        ///< mu_pp (also projectile-bead)
  double friction_bead_wall = 0.15;        ///< mu_pw (also projectile-plate and -wall)
  /// mu_r, rolling resistance of every contact in the impact; 0: none, as in the paper. Beds
  /// are prepared without it (it only dissipates, so a bed at rest stays at rest).
  double rolling_friction = 0.0;
  /// [choice] "paper": G* = G/(2(1-nu)) as the paper; "mindlin": G* = G/(2(2-nu)).
  std::string shear_stiffness = "paper";
};

/// Material of the plate and cylinder wall. [choice] By default they have the beads' E and nu.
struct WallSpec {
  bool material_from_beads = true;
  double youngs_modulus_Pa = 5.0e9;  ///< used when material_from_beads is false
  double poisson_ratio = 0.22;       ///< used when material_from_beads is false
};

/// Bead size distribution: diameters uniform in [diameter_min_m, diameter_max_m].
struct BeadSpec {
  double diameter_min_m = 0.004;
  double diameter_max_m = 0.005;
  /// The mean diameter d of the uniform distribution: the calibration's and the rest
  /// criterion's bead, the peak rule's unit of depth.
  double MeanDiameter() const { return 0.5 * (diameter_min_m + diameter_max_m); }
};

/// The most species a bed may mix: the first (material.*, beads.*) and species2, species3.
inline constexpr int kMaxSpecies = 3;

/// A further bead species (docs/model.md "Species"): its material, sizes and its own pairs'
/// restitution and friction. Its pairs with another species follow PairRulesSpec. It is in the
/// bed when a layer mixes it in (LayerSpec::fraction).
struct SpeciesSpec {
  std::string name;
  double density_kg_m3 = 7850.0;  ///< defaults: steel shot
  double youngs_modulus_Pa = 2.0e11;
  double poisson_ratio = 0.30;
  double restitution = 0.80;         ///< e of two of its mean beads at material's v_ref
  double friction_bead_bead = 0.50;  ///< mu of two of its beads
  double friction_bead_wall = 0.15;  ///< mu of its beads with plate and wall
  double diameter_min_m = 0.004;
  double diameter_max_m = 0.005;
  double MeanDiameter() const { return 0.5 * (diameter_min_m + diameter_max_m); }
};

/// The pairs of two different species: restitution and friction given per pair, or by the
/// rules (docs/model.md "Species"): e the mean of the two species' e, mu the smaller of their
/// mu. 0 (restitution) and -1 (friction): by the rule.
struct PairRulesSpec {
  double restitution_1_2 = 0.0, restitution_1_3 = 0.0, restitution_2_3 = 0.0;
  double friction_1_2 = -1.0, friction_1_3 = -1.0, friction_2_3 = -1.0;
};

/// One layer of the bed, counted from the plate up: its thickness and its mixture, the volume
/// fractions of species 2 and 3 (species 1 takes the rest). A layer with a thickness has
/// another above it; the last layer (thickness 0) fills the bed up to H.
struct LayerSpec {
  double thickness_m = 0.0;
  double fraction2 = 0.0;
  double fraction3 = 0.0;
};

/// The most layers a bed may have.
inline constexpr int kMaxLayers = 3;

/// The granular bed. Thickness 0 means no beads: the projectile hits the bare plate.
struct BedSpec {
  double thickness_m = 0.0;     ///< H, settled thickness
  double prep_friction = 0.50;  ///< bead friction while settling; controls the packing C0
  std::int64_t seed = 1;        ///< random seed of the bead insertion
  std::string import;           ///< bed file (text, LAMMPS data or dump); empty: prepare a bed
  /// The bytes of bed.import when they came with a request rather than from this machine's
  /// disk (a bed file sent to the daemon): read instead of the file. Not a scene field: the
  /// scene text names the file, and the bed's hash covers these bytes.
  std::shared_ptr<const std::string> import_bytes;
  /// The SHA-256 of import_bytes (hex) when whoever gave them knows it (the daemon keeps its
  /// sent files by it), so that a sweep of many runs does not hash them once a run; "" to
  /// compute it. Not a scene field either.
  std::string import_sha256;
  /// What to do with an imported bed whose beads overlap by more than a settled bed's resting
  /// contacts (1% of a radius): "refuse" it, naming the worst bead, or "relax": separate them.
  std::string import_overlaps = "refuse";
  /// The length unit of bed.import's numbers: "m", "cm", "mm" or "um" (a text file's header
  /// may name its own per column).
  std::string import_units = "m";
  /// How many species bed.import's atom types (a LAMMPS file's type, a text file's type or
  /// species column) are: type k is species k. 1: every bead is species 1, whatever its type.
  std::int64_t import_types = 1;
  /// Beds are cut from one settled bed of this thickness, so that every H of a study shares
  /// one settling (a bed thicker than this minus d_max gets a source of H + 2 d_max, and one
  /// whose top layer mixes species is poured to H: docs/model.md, "Mixtures and layers").
  double source_thickness_m = 0.09;
  /// How the source bed is cut to thickness H: "surface" keeps the beads whose centres lie
  /// below the height that puts the measured mean surface at H; "tops" keeps only the beads
  /// whose tops are below H, so that no bead reaches above it (the bed comes out about a bead
  /// radius thinner). The paper does not say which it used (docs/reproduction.md).
  std::string cut = "surface";
  /// Rest: mean kinetic energy per bead below this fraction of m g d (mean bead), and plate +
  /// wall support within 1% of the bed's weight.
  double settle_tolerance = 1e-5;
  /// The same, for the relaxation after a friction change; 0: settle_tolerance. A bed whose
  /// friction drops to zero keeps creeping for long at a few 1e-4 m g d per bead (normal
  /// damping does not dissipate sliding), so the friction study may accept a looser rest.
  double friction_settle_tolerance = 0.0;
  /// Relax a cut bed with kinetic damping: every bead's velocity is zeroed whenever the beads'
  /// kinetic energy passes a maximum, until the maxima fall below settle_tolerance; then the
  /// bed relaxes freely to the same rest criterion. Several times faster than a free
  /// relaxation, with a slightly different packing (docs/accuracy-cost.md); the draft accuracy.
  bool quench_cut_relaxation = false;
  /// Once the bulk of a settling bed (source or cut) carries its weight, step only the
  /// neighbourhood of the beads still moving, holding the beads around it in place and
  /// stopping the rest; rest is still judged on the whole bed. Two to three times faster, with
  /// the impacts' P and the beds' C0 within the seeds' scatter of settling every bead to the
  /// end, which `false` does (docs/accuracy-cost.md).
  bool local_settling = true;
  /// In the local settling of a cut bed, stop each bead whose kinetic energy has passed a
  /// maximum. The cut's spring-back sets the beads near the new surface rocking in their
  /// pockets, and left alone they tap each other denser for a hundred milliseconds, which a
  /// bed poured to its thickness does not go through: this brings the cut beds' C0 closer to
  /// such a bed's, two to three times faster (docs/accuracy-cost.md). No effect without
  /// local_settling.
  bool quench_cut_beads = true;
  /// Time-step factor of the relaxation of the bed cut to H: dt = cut_alpha * critical step
  /// of eq. 6, from time.alpha to 1; 0: automatic, four times time.alpha, at most 0.8, and
  /// time.alpha with quench_cut_relaxation (CutRelaxationAlpha). A cut only unloads a bed at rest,
  /// and its contacts, pressed by the beads' weight, are far softer than eq. 6's step assumes, so
  /// the relaxation stays stable at steps the impact cannot take. Its beds against those relaxed at
  /// time.alpha's step (cut_alpha = time.alpha) are measured in docs/accuracy-cost.md.
  double cut_alpha = 0.0;
  /// Settle the source bed with Young's modulus (beads and walls) divided by this: the time
  /// step grows by its square root. Then the true stiffness is restored and the bed relaxed to
  /// rest again, with kinetic damping; the cut beds relax at the true stiffness. 0: automatic,
  /// the largest factor up to 100 that keeps the pour's overlaps within 10% of a radius
  /// (SoftSettlingFactor); 1: the true stiffness throughout (docs/accuracy-cost.md).
  double soft_settling = 0.0;
  double max_settle_s = 3.0;      ///< give up settling after this much simulated time
  double friction_ramp_s = 0.01;  ///< duration of the change from prep_friction to mu_pp
};

/// The spherical projectile, dropped on the bed's axis unless offset from it.
struct ProjectileSpec {
  bool enabled = true;
  double diameter_m = 0.050;  ///< D
  double mass_kg = 0.167;     ///< M; [choice] density follows from D and M
  double speed_m_s = 0.0;     ///< V0, downward
  double height_m = 0.50;     ///< H1, centre height above the bed surface
  /// Horizontal distance of the drop line from the cylinder's axis (along x). The paper drops
  /// on the axis; radius - diameter/2 grazes the wall.
  double offset_m = 0.0;
};

struct TimeSpec {
  double alpha = 0.2;                 ///< dt = alpha * critical time step (paper eq. 6)
  double end_s = 0.0;                 ///< stop at this time; 0: stop when the impact is over
  double impact_window_s = 0.05;      ///< automatic end: at most this long after first contact
  double output_interval_s = 1.0e-5;  ///< spacing of the written force samples
};

/// Optional outputs beyond the force series.
struct OutputSpec {
  /// Times at which to record the contact network, plate load map and force statistics.
  std::vector<double> snapshot_times_s;
  /// Times after the projectile's first contact at which to record them.
  std::vector<double> snapshot_after_contact_s;
  /// Also record them at the instant of the peak plate force (runs the impact twice).
  bool snapshot_at_peak = false;
  /// Width of the vertical slice through the axis that force-chain pictures draw (two mean
  /// bead diameters by default: a chain in the slice is one layer of beads deep).
  double chain_slab_width_m = 0.009;
  /// Spacing of the animation frames of the beads during the impact (frames/*.vtp and
  /// frames.pvd, for ParaView); 0: none.
  double animation_interval_s = 0.0;
  /// The frames' files: "vtp" (ParaView), "lammps" (frames/*.dump, for OVITO) or "both".
  std::string frame_format = "vtp";
};

/// The most animation frames a run writes (output.animation_interval_s).
inline constexpr double kMaxAnimationFrames = 1000;

/// Damping of the beads' own motion during the impact, besides their contacts' (dem::BeadDamping,
/// docs/model.md "Particle damping"): not in the paper's model, off by default. Bed preparation
/// is not damped: a bed is the same with or without it.
struct BeadDampingSpec {
  double local_alpha = 0.0;         ///< local (non-viscous) damping coefficient, 0 <= alpha < 1
  double viscous_rate_per_s = 0.0;  ///< viscous background damping rate
};

struct Scene {
  CylinderSpec cylinder;
  MaterialSpec material;
  WallSpec walls;
  BeadSpec beads;
  BedSpec bed;
  /// Species 2 and 3 (species 1 is material and beads) and their pairs' rules.
  std::array<SpeciesSpec, kMaxSpecies - 1> species = {SpeciesSpec{.name = "steel"},
                                                      SpeciesSpec{.name = "species3"}};
  PairRulesSpec pairs;
  /// The bed's layers from the plate up; one layer of species 1 alone is a bed of one species.
  std::array<LayerSpec, kMaxLayers> layers;
  ProjectileSpec projectile;
  BeadDampingSpec bead_damping;  ///< scene fields damping.*
  TimeSpec time;
  OutputSpec output;
  double gravity_m_s2 = 9.81;

  /// The mass of a bead of the mean diameter: the calibration's and the rest criterion's bead.
  double MeanBeadMass() const {
    const double d = beads.MeanDiameter();
    return material.density_kg_m3 * std::numbers::pi / 6.0 * d * d * d;
  }
};

}  // namespace dembuf
