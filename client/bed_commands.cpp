// dembuf prepare-bed and dembuf bed export: a scene's bed into the bed cache (and out to a
// file), without the impact.
#include <cstdio>

#include "commands.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/errors.h"
#include "exit_codes.h"
#include "interrupts.h"
#include "progress.h"
#include "scene_input.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

// Prepares a scene's bed (or only its source bed) into the bed cache, and nothing else: a
// cluster runs this as a job of its own that the impacts cutting the bed wait for.
// prepare-bed, and bed export (which writes the bed too).
int PrepareBedCommand(const RunOptions& opt) {
  const Scene scene = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  if (!opt.export_out.empty() && fs::exists(opt.export_out) && !opt.force) {
    std::fprintf(stderr, "dembuf: error: %s exists; choose another --out or pass --force\n",
                 opt.export_out.c_str());
    return kExitRuntime;
  }
  const fs::path dir = BedCacheDir(opt);
  if (dir.empty())
    throw SceneError("--bed-cache", "prepare-bed keeps the bed in a bed cache: give a folder");
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
    if (!opt.export_out.empty()) {
      char title[160];
      std::snprintf(title, sizeof title, "dembuf %s bed %s, %zu beads, H = %.5f m",
                    bed.stage.c_str(), bed.hash.c_str(), bed.beads.size(), bed.surface_m);
      report::WriteFileAtomically(
          opt.export_out, ExportBed(bed.beads, scene, *ParseBedFormat(opt.export_format), title));
      std::printf("wrote %s (%s)\n", opt.export_out.c_str(), opt.export_format.c_str());
    }
    return 0;
  } catch (const dem::SimulationError& e) {
    std::fprintf(stderr, "dembuf: bed preparation failed: %s\n", e.what());
    return kExitFailed;
  } catch (const Cancelled&) {
    std::fprintf(stderr, "dembuf: bed preparation interrupted by %s\n", InterruptName());
    return InterruptedExit();
  }
}

}  // namespace dembuf::cli
