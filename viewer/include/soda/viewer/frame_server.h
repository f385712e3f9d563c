// viewer/ — the HTTP frame server behind `soda view FILE` and `soda run
// --serve PORT`: serves the browser viewer's static files (viewer/web and
// three.js from Debian's libjs-three) and any FrameSource's frames, on
// 127.0.0.1 only. Endpoints (docs/viewer.md):
//   GET /header               the ViewHeader as JSON (frame_codec.h)
//   GET /range                {"first", "last", "finished"}
//   GET /frame?after=N        the newest frame with step > N, 204 if none yet
//   GET /frame?at=N           the frame at exactly step N, 404 if not held
//       (&format=json for JSON; the binary record of frame_codec.h otherwise)
//   GET /, /index.html, ...   viewer/web;  GET /three/...  three.js
// The server only reads the source when a request comes: a slow or absent
// browser costs the source nothing (a live source's pump reads the worlds
// on its own, live_frame_source.h).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "soda/replay/view_frame.h"

namespace soda::viewer {

/// Where the viewer's static files are by default (set by CMake: the
/// source tree's viewer/web, Debian's /usr/share/javascript/three).
std::string default_web_dir();
std::string default_three_dir();

struct FrameServerOptions {
  int port = 0;                   // 0: any free port (see FrameServer::port())
  std::string web_dir;            // empty: $SODA_VIEWER_DIR, else default_web_dir()
  std::string three_dir;          // empty: default_three_dir()
};

/// An HTTP server on 127.0.0.1 over one FrameSource, answering on a thread
/// pool of its own. Thread safety: start/stop/port/url from one owning
/// thread; the source is called from the server's threads (FrameSource
/// implementations are thread-safe by contract).
class FrameServer {
 public:
  /// Does not bind yet. Throws std::invalid_argument if the web or three.js
  /// folder is missing (naming it and the package that provides it).
  FrameServer(std::shared_ptr<replay::FrameSource> source, FrameServerOptions options = {});
  /// stop().
  ~FrameServer();
  FrameServer(const FrameServer&) = delete;
  FrameServer& operator=(const FrameServer&) = delete;

  /// Binds 127.0.0.1:port and starts answering on a thread. Returns the port
  /// bound. Throws std::runtime_error if the port cannot be bound.
  int start();
  /// Stops answering and joins the thread; idempotent.
  void stop();
  /// The port bound (0 before start()).
  int port() const;
  /// "http://127.0.0.1:PORT/".
  std::string url() const;
  /// Requests for /frame received so far (a viewer has loaded the page, its
  /// header and range, and asks for frames). Any thread.
  std::int64_t frame_requests() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace soda::viewer
