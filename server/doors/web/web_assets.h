// The files of the web pages (HTML, CSS, scripts, the vendored chart library), compiled into
// dembufd from server/doors/web/assets/ so that an installed daemon needs no folder of its own and
// serves nothing but these.
#pragma once

#include <string_view>

namespace dembuf::server::web {

struct WebAsset {
  std::string_view name;  ///< e.g. "job.html", "uPlot.iife.min.js"
  std::string_view content_type;
  std::string_view bytes;
};

/// The file of that name, or nullptr.
const WebAsset* FindWebAsset(std::string_view name);

}  // namespace dembuf::server::web
