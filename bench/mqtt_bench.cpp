// Many cameras, many renderers through one MQTT broker on loopback (issue 19): N camera
// nodes (replay publishers: MqttPublisher, QoS 1, retained, a 64-light list stamped with
// the wall clock when it is "captured", at a fixed rate) and M subscribers (one
// connection each, QoS 1 on PREFIX/+/lights) through a mosquitto the benchmark starts
// with its own config. Not a timed test: numbers to read.
//   p50_ms / p99_ms: capture (the list's timestamp) -> a subscriber's callback
//   lost: lists some subscriber never got (of every list sent while all were subscribed;
//         must be 0 at QoS 1); dropped: lists the publishers' keep-latest replaced
//   broker_cpu: CPU seconds per wall second of the broker; clients_cpu: the same of this
//         process, which holds all camera nodes and all subscribers (the nodes' share is
//         not separable in one process: the subscribers' parsing dominates it)
//   build/bench/lightprobe_bench --benchmark_filter=Mqtt --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "live/mqtt_client.h"
#include "live/mqtt_publisher.h"

extern char** environ;

namespace {

using namespace lp;
namespace fs = std::filesystem;

double wall_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

int free_port() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  close(s);
  return ntohs(a.sin_port);
}

// CPU seconds (user + system) of a process, from /proc.
double cpu_seconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::istringstream rest(text.substr(text.rfind(')') + 2));
  std::string field;
  double utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / double(sysconf(_SC_CLK_TCK));
}

double own_cpu_seconds() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return double(r.ru_utime.tv_sec + r.ru_stime.tv_sec) + 1e-6 * double(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

// A mosquitto of our own: loopback, no persistence, queues deep enough for QoS 1 bursts.
struct Broker {
  pid_t pid = -1;
  int port = 0;
  fs::path dir;
  bool start() {
    const char* candidates[] = {"/usr/sbin/mosquitto", "/usr/bin/mosquitto", "/usr/local/sbin/mosquitto"};
    const char* exe = nullptr;
    for (const char* c : candidates)
      if (access(c, X_OK) == 0) exe = c;
    if (!exe) return false;
    dir = fs::temp_directory_path() / ("lightprobe_mqtt_bench_" + std::to_string(getpid()));
    fs::create_directories(dir);
    port = free_port();
    std::ofstream(dir / "mosquitto.conf") << "listener " << port << " 127.0.0.1\nallow_anonymous true\n"
                                          << "persistence false\nmax_queued_messages 100000\n";
    const std::string conf = (dir / "mosquitto.conf").string();
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    char* argv[] = {const_cast<char*>(exe), const_cast<char*>("-c"), const_cast<char*>(conf.c_str()), nullptr};
    const int rc = posix_spawn(&pid, exe, &fa, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) return false;
    for (int i = 0; i < 100; ++i) {  // until it listens
      const int s = socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in a{};
      a.sin_family = AF_INET;
      a.sin_port = htons(uint16_t(port));
      a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      const bool up = connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
      close(s);
      if (up) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
  ~Broker() {
    if (pid > 0) kill(pid, SIGTERM), waitpid(pid, nullptr, 0);
    if (!dir.empty()) fs::remove_all(dir);
  }
};

LightList replay_list(int cameras_seed) {
  LightList l;
  l.method = "q2tree";
  for (int i = 0; i < 64; ++i) {
    const double z = 1 - (i + 0.5) / 64, r = std::sqrt(1 - z * z), phi = 2.39996 * (i + cameras_seed);
    Light light;
    light.id = uint64_t(i);
    light.direction = {r * std::cos(phi), r * std::sin(phi), z};
    light.rgb = {0.1, 0.2, 0.3};
    light.solid_angle = 4 * M_PI / 64;
    l.lights.push_back(light);
  }
  return l;
}

// What one subscriber saw: per camera, which frames; every latency.
struct Seen {
  std::mutex mutex;
  std::vector<std::vector<char>> frames;  // [camera][frame]
  std::vector<double> latency_ms;
};

// "frame": and "timestamp": read without a full parse (64 subscribers, one core each not).
bool read_stamp(std::string_view p, int64_t* frame, double* timestamp) {
  const auto f = p.find("\"frame\":"), t = p.find("\"timestamp\":");
  if (f == std::string_view::npos || t == std::string_view::npos) return false;
  *frame = std::strtoll(std::string(p.substr(f + 8, 24)).c_str(), nullptr, 10);
  *timestamp = std::strtod(std::string(p.substr(t + 12, 32)).c_str(), nullptr);
  return true;
}

void BM_Mqtt_Fanout(benchmark::State& state) {
  const int cameras = int(state.range(0)), subscribers = int(state.range(1)), rate_hz = int(state.range(2));
  const int frames = rate_hz * 10;  // 10 s of publishing
  for (auto _ : state) {
    Broker broker;
    if (!broker.start()) {
      state.SkipWithError("mosquitto not installed or did not start");
      return;
    }
    const std::string base = "mqtt://127.0.0.1:" + std::to_string(broker.port) + "/bench";
    MqttUrl url = parse_mqtt_url(base + "/+/lights", "bench");
    std::vector<std::unique_ptr<Seen>> seen;
    std::vector<std::unique_ptr<MqttConnection>> subs;
    for (int s = 0; s < subscribers; ++s) {
      seen.push_back(std::make_unique<Seen>());
      Seen* mine = seen.back().get();
      mine->frames.assign(size_t(cameras), std::vector<char>(size_t(frames), 0));
      auto conn = std::make_unique<MqttConnection>(
          url, "bench", MqttClientOptions{}, std::nullopt, [] {},
          [mine, cameras, frames](const std::string& topic, std::string_view payload) {
            const double now = wall_s();
            int64_t frame = -1;
            double ts = 0;
            const auto slash = topic.find("/cam");
            if (slash == std::string::npos || !read_stamp(payload, &frame, &ts)) return;
            const int cam = std::atoi(topic.c_str() + slash + 4);
            if (cam < 0 || cam >= cameras || frame < 0 || frame >= frames) return;
            std::lock_guard lock(mine->mutex);
            mine->frames[size_t(cam)][size_t(frame)] = 1;
            mine->latency_ms.push_back(1e3 * (now - ts));
          });
      subs.push_back(std::move(conn));
    }
    // Subscribing happens in each connection's OnConnect, which needs the connection
    // itself: done here once all are up instead (a clean start, no reconnects expected).
    for (auto& c : subs) c->start();
    for (int i = 0; i < 200; ++i) {
      bool all = true;
      for (auto& c : subs) all = all && c->stats().connected;
      if (all) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    for (auto& c : subs) c->subscribe("bench/+/lights", 1);
    std::vector<std::unique_ptr<MqttPublisher>> nodes;
    for (int c = 0; c < cameras; ++c) {
      MqttPublisherOptions po;
      po.camera = "cam" + std::to_string(c);
      po.qos = 1;
      nodes.push_back(std::make_unique<MqttPublisher>(base, "bench", po));
      nodes.back()->start();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // connected and subscribed

    const double cpu0 = own_cpu_seconds(), broker0 = cpu_seconds(broker.pid), t0 = wall_s();
    std::vector<std::thread> replays;
    for (int c = 0; c < cameras; ++c)
      replays.emplace_back([&, c] {
        LightList l = replay_list(c);
        const auto start = std::chrono::steady_clock::now();
        for (int f = 0; f < frames; ++f) {
          std::this_thread::sleep_until(start + std::chrono::microseconds(int64_t(1e6 * f / rate_hz)));
          l.frame = f;
          l.timestamp = wall_s();  // "captured" now
          nodes[size_t(c)]->publish(l);
        }
      });
    for (auto& t : replays) t.join();
    std::this_thread::sleep_for(std::chrono::seconds(3));  // the last deliveries
    const double wall = wall_s() - t0;
    const double cpu = own_cpu_seconds() - cpu0, broker_cpu = cpu_seconds(broker.pid) - broker0;

    uint64_t dropped = 0, lost = 0;
    for (auto& n : nodes) dropped += n->stats().lists_dropped;
    std::vector<double> lat;
    for (auto& s : seen) {
      std::lock_guard lock(s->mutex);
      for (const auto& cam : s->frames) lost += uint64_t(std::count(cam.begin(), cam.end(), 0));
      lat.insert(lat.end(), s->latency_ms.begin(), s->latency_ms.end());
    }
    for (auto& n : nodes) n->stop();
    for (auto& c : subs) c->stop();
    std::sort(lat.begin(), lat.end());
    const auto pct = [&](double q) { return lat.empty() ? NAN : lat[size_t(q * double(lat.size() - 1))]; };
    state.counters["p50_ms"] = pct(0.5);
    state.counters["p99_ms"] = pct(0.99);
    state.counters["max_ms"] = lat.empty() ? NAN : lat.back();
    state.counters["delivered"] = double(lat.size());
    state.counters["lost"] = double(lost);
    state.counters["dropped"] = double(dropped);
    state.counters["broker_cpu"] = broker_cpu / wall;
    state.counters["clients_cpu"] = cpu / wall;
  }
}
// 8 cameras at 10 lists/s to 64 subscribers: 5 120 deliveries a second of ~8 KB lists.
BENCHMARK(BM_Mqtt_Fanout)->Args({8, 64, 10})->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
