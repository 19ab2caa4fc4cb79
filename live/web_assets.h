// The static files the live page loads from the server besides itself: three.js (MIT,
// npm's `three`, pinned in tools/js/package.json) for the 3D preview, embedded into the
// binary at build time (live/CMakeLists.txt) so that the page needs no network at run
// time. A build made where the npm package was absent has none: the routes answer 404 and
// the page shows a one-line notice instead of the preview.
//
// Routes: /three/three.module.js and /three/three.core.js (the module imports the core
// by that relative name). They are public like the page: library code, no data.
#pragma once

#include <string_view>

#include "live/http_server.h"

namespace lp {

// True when this binary carries three.js.
bool have_three_js();

// Answers a GET or HEAD of a static asset (200 with a strong ETag and "no-cache", or 304
// for a matching If-None-Match); false when `path` names none (the caller answers 404).
bool answer_web_asset(const HttpRequest& request, HttpExchange& exchange);

}  // namespace lp
