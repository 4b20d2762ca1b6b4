// Files of a contact-network snapshot, in snapshots/<label>/ of a run's folder:
//   snapshot.json     when it was taken (simulated time, time after the first contact), counts
//   beads.vtp         beads (vertices with radius, velocity, id, force) and projectile, for
//                     ParaView (VTK XML, vtk_files.h)
//   contacts.vtp      bead/projectile contacts (lines between centres, normal force)
//   contacts.csv      every contact: bodies, contact point, force vector, normal force
//   plate_radial.csv  plate load by ring of width one bead diameter: force and pressure
//   plate_map.csv     plate load on a square grid of 1 cm cells
//   force_pdf.csv     probability density of bead-bead normal forces over their mean
// snapshots.pvd in the run's folder collects the snapshots' .vtp files with their times.
// Animation frames (output.animation_interval_s) are frames/frame_NNNNN.vtp, collected by
// frames.pvd. They are made in memory, so that a local run writes them to its folder and the
// daemon stores them with the job; both give the same bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "dembuf/study/files/vtk_files.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf::report {

/// One file of a run's results: its path relative to the run's folder, and its bytes.
struct ResultFile {
  std::string path;
  std::string data;
};

/// How many files one snapshot has (what a reader of a run folder may expect of it).
inline constexpr std::size_t kSnapshotFileCount = 7;

/// The files of one snapshot, under "snapshots/<label>/": kSnapshotFileCount of them.
std::vector<ResultFile> SnapshotFiles(const ImpactSnapshot& snap, double cylinder_radius_m,
                                      double bead_diameter_m);

/// A run's ParaView files as they come: each snapshot or frame gives its files and the .pvd
/// collection updated to hold it, so that the folder opens in ParaView at any moment.
class ParaViewFiles {
 public:
  ParaViewFiles(double cylinder_radius_m, double cylinder_height_m, double bead_diameter_m)
      : m_cylinder_radius_m(cylinder_radius_m),
        m_cylinder_height_m(cylinder_height_m),
        m_bead_diameter_m(bead_diameter_m) {}
  /// SnapshotFiles and snapshots.pvd (and container.vtp with the first snapshot or frame).
  std::vector<ResultFile> AddSnapshot(const ImpactSnapshot& snap);
  /// frames/<label>.vtp and frames.pvd (and container.vtp with the first).
  std::vector<ResultFile> AddFrame(const ImpactSnapshot& frame);

 private:
  // container.vtp, the first time a snapshot or frame is written.
  void AddContainerOnce(std::vector<ResultFile>& files);

  double m_cylinder_radius_m, m_cylinder_height_m, m_bead_diameter_m;
  bool m_container_written = false;
  std::vector<PvdEntry> m_snapshots, m_frames;
};

/// An animation frame's file: frames/LABEL.vtp or frames/LABEL.dump (extension ".vtp" or
/// ".dump", the only ones IsResultFileName allows), LABEL as SafeLabel makes it.
std::string FramePath(const ImpactSnapshot& frame, std::string_view extension);

/// Whether `path` may name a result file: relative, made of folder and file names of letters,
/// digits, '.', '-' and '_' (none of them "." or ".."), at most kMaxResultPathLength long and
/// kMaxResultPathDepth deep. Result files come from a cluster's shared folder and from a
/// server's answers: a name that could leave the run's folder is refused.
bool IsSafeResultPath(std::string_view path);
inline constexpr std::size_t kMaxResultPathLength = 200;
inline constexpr int kMaxResultPathDepth = 3;

/// The files and folders of a run's folder that hold its result files (IsResultFileName),
/// for reading them back from a cluster's shared folder.
const std::vector<std::string>& ResultFileRoots();

/// Whether `path` is the name of a result file a run writes besides its series and summary:
/// plate_force_bare.csv, snapshots.pvd, frames.pvd, container.vtp, snapshots/LABEL/ one of the
/// files of SnapshotFiles, or frames/LABEL.vtp or .dump, LABEL as SafeLabel makes it (never
/// starting with a dot). An allow-list, not a rule about characters: what a server or a cluster's
/// folder sends under any other name (.git/config, .envrc, a/b where a is a file) is refused.
bool IsResultFileName(std::string_view path);

/// Writes the files under `dir` (each atomically), creating their folders. Throws
/// std::runtime_error for a path IsSafeResultPath refuses, before writing anything.
void WriteResultFiles(const std::vector<ResultFile>& files, const std::filesystem::path& dir);

}  // namespace dembuf::report
