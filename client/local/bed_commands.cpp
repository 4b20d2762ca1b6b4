// dembuf prepare-bed and dembuf bed export: a scene's bed into the bed cache (and out to a
// file), without the impact.
#include <cstdio>
#include <functional>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/errors.h"
#include "local/commands.h"
#include "local/scene_input.h"
#include "terminal/exit_codes.h"
#include "terminal/interrupts.h"
#include "terminal/progress.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

// The scene's bed (or with --source-only its source bed) from the bed cache, prepared first
// when it is not there, with a progress line; then `then(bed)`, whose exit code it returns.
int WithPreparedBed(const CommandOptions& opt, const Scene& scene,
                    const std::function<int(const PreparedBed&)>& then) {
  const fs::path dir = BedCacheDir(opt);
  if (dir.empty())
    throw SceneError("--bed-cache",
                     "prepare-bed and bed export keep the bed in a bed cache: give a folder");
  BedCache beds(dir);
  CatchInterrupts();
  BedRequest request;
  request.cancel = &Interrupted();
  BedProgressLine progress(stderr);
  request.on_progress = [&](const BedProgress& p) { progress.Update(p); };
  try {
    const PreparedBed bed =
        opt.source_only ? GetSourceBed(scene, beds, request) : GetBed(scene, beds, request);
    if (progress.open()) std::fprintf(stderr, "\n");
    std::printf("%s bed %s: %zu beads, H = %.5f m, C0 = %.4f, in %s\n", bed.stage.c_str(),
                bed.hash.c_str(), bed.beads.size(), bed.surface_m, bed.solid_fraction, dir.c_str());
    return then(bed);
  } catch (const dem::SimulationError& e) {
    std::fprintf(stderr, "dembuf: bed preparation failed: %s\n", e.what());
    return kExitFailed;
  } catch (const Cancelled&) {
    std::fprintf(stderr, "dembuf: bed preparation interrupted by %s\n", InterruptName());
    return InterruptedExit();
  }
}

}  // namespace

// The bed into the cache and nothing else: a cluster runs this as a job of its own that the
// impacts cutting the bed wait for.
int PrepareBedCommand(const CommandOptions& opt) {
  const Scene scene = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  return WithPreparedBed(opt, scene, [](const PreparedBed&) { return 0; });
}

int ExportBedCommand(const CommandOptions& opt) {
  const Scene scene = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  // What the file cannot be is said before the bed is prepared (which may take minutes).
  if (opt.export_out.empty()) throw SceneError("--out", "give the file to write");
  const fs::path out(opt.export_out);
  if (fs::is_directory(out)) throw SceneError("--out", opt.export_out + " is a folder");
  if (const fs::path folder = out.parent_path(); !folder.empty() && !fs::is_directory(folder))
    throw SceneError(
        "--out", "no folder " + folder.string() + " to write " + out.filename().string() + " into");
  if (fs::exists(opt.export_out) && !opt.force) {
    std::fprintf(stderr, "dembuf: error: %s exists; choose another --out or pass --force\n",
                 opt.export_out.c_str());
    return kExitRuntime;
  }
  return WithPreparedBed(opt, scene, [&](const PreparedBed& bed) {
    char title[160];
    std::snprintf(title, sizeof title, "dembuf %s bed %s, %zu beads, H = %.5f m", bed.stage.c_str(),
                  bed.hash.c_str(), bed.beads.size(), bed.surface_m);
    report::WriteFileAtomically(
        opt.export_out, ExportBed(bed.beads, scene, *ParseBedFormat(opt.export_format), title));
    std::printf("wrote %s (%s)\n", opt.export_out.c_str(), opt.export_format.c_str());
    return 0;
  });
}

}  // namespace dembuf::cli
