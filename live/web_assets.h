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

// Answers a GET or HEAD under /three/: 200 with a strong ETag and "no-cache", 304 for a
// matching If-None-Match, 404 for any other name (or every name in a build without
// three.js), all without a token; false for paths elsewhere.
bool answer_web_asset(const HttpRequest& request, HttpExchange& exchange);

}  // namespace lp
