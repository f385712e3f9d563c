#include "soda/viewer/frame_server.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <atomic>
#include <chrono>
#include <thread>

#include <httplib.h>

#include "soda/viewer/frame_codec.h"

namespace soda::viewer {
namespace {

// Every open keep-alive connection holds a server thread (httplib), and a
// browser opens about six to load the page's modules: with httplib's
// default pool (8 threads here) a later request waited for an idle
// connection to time out (seen: /range answered ~2 s late). Enough threads
// for a few browser tabs, and idle connections closed after a second.
constexpr std::size_t kServerThreads = 32;
constexpr int kKeepAliveSeconds = 1;
constexpr int kReadTimeoutSeconds = 2;
// The loopback interface only: the viewer is for the user at this machine.
constexpr const char* kHost = "127.0.0.1";

std::optional<std::int64_t> step_param(const httplib::Request& req, const char* name) {
  if (!req.has_param(name)) return std::nullopt;
  const std::string text = req.get_param_value(name);
  try {
    std::size_t used = 0;
    const long long v = std::stoll(text, &used);
    if (used != text.size()) throw std::invalid_argument(text);
    return v;
  } catch (const std::exception&) {
    throw std::invalid_argument(std::string("query parameter '") + name + "' must be an integer step, got '" + text +
                                "'");
  }
}

// "1,2,3" -> ids; at most kMaxBodiesAsked of them.
constexpr std::size_t kMaxBodiesAsked = 100000;
std::vector<BodyId> id_list(const std::string& text) {
  std::vector<BodyId> ids;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, end - at);
    std::size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || item[0] == '-' || v > kMaxBodyId)
      throw std::invalid_argument("query parameter 'ids' must be body ids separated by commas, got '" + item + "'");
    ids.push_back(static_cast<BodyId>(v));
    if (ids.size() > kMaxBodiesAsked)
      throw std::invalid_argument("query parameter 'ids': more than " + std::to_string(kMaxBodiesAsked) + " ids");
    at = end + 1;
  }
  return ids;
}

}  // namespace

struct FrameServer::Impl {
  std::shared_ptr<replay::FrameSource> source;
  FrameServerOptions options;
  httplib::Server server;
  std::thread thread;
  int port = 0;
  std::atomic<std::int64_t> frame_requests{0};

  void send_frame(const std::optional<replay::ViewFrame>& frame, bool json, int missing_status,
                  httplib::Response& res) {
    if (!frame) {
      res.status = missing_status;
      return;
    }
    const bool finished = source->finished() && frame->step >= source->step_range().second;
    if (json)
      res.set_content(frame_json(*frame, finished).dump(), "application/json");
    else
      res.set_content(frame_binary(*frame, finished), "application/octet-stream");
  }

  void routes() {
    // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, which lets a
    // second server bind a port in use and share its requests.
    server.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    server.set_default_headers({{"Cache-Control", "no-store"}});
    server.set_read_timeout(kReadTimeoutSeconds, 0);
    server.set_keep_alive_timeout(kKeepAliveSeconds);
    server.new_task_queue = [] { return new httplib::ThreadPool(kServerThreads); };
    server.set_file_extension_and_mimetype_mapping("js", "text/javascript");
    server.set_mount_point("/three", options.three_dir);
    server.set_mount_point("/", options.web_dir);
    server.Get("/header", [this](const httplib::Request&, httplib::Response& res) {
      res.set_content(header_json(source->header()).dump(), "application/json");
    });
    // Bodies a frame holds that the header lacks (added during the run):
    // /bodies?ids=1,2,3 -> {"bodies": [...], "unknown": [ids the source
    // does not know]}.
    server.Get("/bodies", [this](const httplib::Request& req, httplib::Response& res) {
      nlohmann::json bodies = nlohmann::json::array(), unknown = nlohmann::json::array();
      try {
        for (BodyId id : id_list(req.has_param("ids") ? req.get_param_value("ids") : std::string()))
          if (const std::optional<replay::ViewBody> b = source->body(id)) bodies.push_back(body_json(*b));
          else unknown.push_back(id);
      } catch (const std::invalid_argument& e) {
        res.status = 400;
        res.set_content(e.what(), "text/plain");
        return;
      }
      res.set_content(nlohmann::json{{"bodies", std::move(bodies)}, {"unknown", std::move(unknown)}}.dump(),
                      "application/json");
    });
    server.Get("/range", [this](const httplib::Request&, httplib::Response& res) {
      const auto [first, last] = source->step_range();
      const nlohmann::json j = {{"first", first}, {"last", last}, {"finished", source->finished()}};
      res.set_content(j.dump(), "application/json");
    });
    server.Get("/frame", [this](const httplib::Request& req, httplib::Response& res) {
      ++frame_requests;
      try {
        const bool json = req.has_param("format") && req.get_param_value("format") == "json";
        if (const auto at = step_param(req, "at")) return send_frame(source->frame_at(*at), json, 404, res);
        const std::int64_t after = step_param(req, "after").value_or(-1);
        send_frame(source->newest_after(after), json, 204, res);
      } catch (const std::invalid_argument& e) {
        res.status = 400;
        res.set_content(e.what(), "text/plain");
      }
    });
    server.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
      res.status = 500;
      try {
        std::rethrow_exception(ep);
      } catch (const std::exception& e) {
        res.set_content(e.what(), "text/plain");
      } catch (...) {
        res.set_content("unknown error", "text/plain");
      }
    });
  }
};

std::string default_web_dir() {
  if (const char* env = std::getenv("SODA_VIEWER_DIR"); env && *env) return env;
  return SODA_VIEWER_WEB_DIR;
}

std::string default_three_dir() { return SODA_VIEWER_THREE_DIR; }

FrameServer::FrameServer(std::shared_ptr<replay::FrameSource> source, FrameServerOptions options)
    : impl_(std::make_unique<Impl>()) {
  if (!source) throw std::invalid_argument("FrameServer: no frame source");
  if (options.web_dir.empty()) options.web_dir = default_web_dir();
  if (options.three_dir.empty()) options.three_dir = default_three_dir();
  if (!std::filesystem::is_regular_file(std::filesystem::path(options.web_dir) / "index.html"))
    throw std::invalid_argument("viewer files not found: " + options.web_dir +
                                "/index.html is missing (set SODA_VIEWER_DIR to the source tree's viewer/web)");
  if (!std::filesystem::is_regular_file(std::filesystem::path(options.three_dir) / "build" / "three.module.js"))
    throw std::invalid_argument("three.js not found: " + options.three_dir +
                                "/build/three.module.js is missing (apt-get install libjs-three; scripts/setup.sh)");
  if (options.port < 0 || options.port > 65535)
    throw std::invalid_argument("port must be in 0..65535, got " + std::to_string(options.port));
  impl_->source = std::move(source);
  impl_->options = std::move(options);
  impl_->routes();
}

FrameServer::~FrameServer() { stop(); }

int FrameServer::start() {
  if (impl_->thread.joinable()) return impl_->port;
  Impl& i = *impl_;
  if (i.options.port == 0) {
    i.port = i.server.bind_to_any_port(kHost);
    if (i.port <= 0) throw std::runtime_error(std::string("cannot bind any port on ") + kHost);
  } else {
    if (!i.server.bind_to_port(kHost, i.options.port))
      throw std::runtime_error(std::string("cannot bind ") + kHost + ":" + std::to_string(i.options.port) +
                               " (in use?)");
    i.port = i.options.port;
  }
  i.thread = std::thread([&i] { i.server.listen_after_bind(); });
  // stop() is a no-op until the server runs: wait for it, so that a stop()
  // right after start() cannot leave the thread listening for ever.
  while (!i.server.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return i.port;
}

void FrameServer::stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->server.stop();
  impl_->thread.join();
}

std::int64_t FrameServer::frame_requests() const { return impl_->frame_requests.load(); }

int FrameServer::port() const { return impl_->port; }

std::string FrameServer::url() const { return "http://127.0.0.1:" + std::to_string(impl_->port) + "/"; }

}  // namespace soda::viewer
