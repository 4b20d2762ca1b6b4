// Beds as files: the plain text exchange format (one bead per line: x y z radius, SI units;
// '#' starts a comment), so that packings made by other codes can be used.
#pragma once

#include <string>

#include "dembuf/engine/particles.h"
#include "dembuf/engine/scene.h"

namespace dembuf {

/// Reads a text bed; every bead gets the scene's density. Throws SceneError (field
/// "bed.import") naming the line of any malformed, non-finite or out-of-container bead.
ParticleState ImportTextBed(const std::string& path, const Scene& scene);

/// Height of the bed surface: the top of the highest bead.
double BedSurfaceHeight(const ParticleState& beads);

}  // namespace dembuf
