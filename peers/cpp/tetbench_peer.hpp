// tetbench_peer.hpp: write a tetbench peer in C++17 (protocol 1.0, docs/peers.md). One header,
// no dependencies beyond the C++ standard library and POSIX.
//
//   #include "tetbench_peer.hpp"
//   struct Mine : tetbench::Peer {
//     tetbench::Info info() override { return {"mine", "0.1", "pt", {"average"}}; }
//     void prepare(const tetbench::Scene& s) override { /* build */ }
//     void render(const tetbench::Camera& c, tetbench::Frame& f) override { /* fill f.rgba */ }
//   };
//   int main() { Mine m; return tetbench::serve(m); }
//
// `serve` owns the protocol: one JSON request a line on stdin, one reply a line on a private
// copy of stdout (fd 1 itself is pointed at stderr, so stray prints land in the peer's log),
// the bulk files read into the Scene, the image written from Frame::rgba, `render` timed when
// the peer does not set draw_ms. An exception thrown by prepare or render becomes the error
// reply (one line), and the peer keeps serving.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tetbench {

inline constexpr const char* kProtocol = "1.0";

// ---- a small JSON value, parser and string escaping ------------------------------------------

struct Json {
  enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
  bool b = false;
  double num = 0;
  std::string str;
  std::vector<Json> arr;
  std::vector<std::pair<std::string, Json>> obj;

  const Json* find(const std::string& k) const {
    for (auto& kv : obj)
      if (kv.first == k) return &kv.second;
    return nullptr;
  }
  const Json& at(const std::string& k) const {
    if (const Json* v = find(k)) return *v;
    throw std::runtime_error("request lacks \"" + k + "\"");
  }
  double number() const {
    if (kind != Number) throw std::runtime_error("expected a number");
    return num;
  }
  const std::string& string() const {
    if (kind != String) throw std::runtime_error("expected a string");
    return str;
  }
};

class JsonParser {
 public:
  explicit JsonParser(const std::string& t) : t_(t) {}
  Json parse() {
    Json v = value(0);
    ws();
    if (i_ != t_.size()) fail("trailing characters");
    return v;
  }

 private:
  const std::string& t_;
  size_t i_ = 0;
  [[noreturn]] void fail(const char* what) {
    throw std::runtime_error(std::string("bad JSON request: ") + what);
  }
  void ws() {
    while (i_ < t_.size() && (t_[i_] == ' ' || t_[i_] == '\t' || t_[i_] == '\r' || t_[i_] == '\n')) ++i_;
  }
  bool lit(const char* w) {
    size_t n = std::char_traits<char>::length(w);
    if (t_.compare(i_, n, w) != 0) return false;
    i_ += n;
    return true;
  }
  static void utf8(std::string& o, unsigned cp) {
    if (cp < 0x80) {
      o += char(cp);
    } else if (cp < 0x800) {
      o += char(0xC0 | (cp >> 6));
      o += char(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      o += char(0xE0 | (cp >> 12));
      o += char(0x80 | ((cp >> 6) & 0x3F));
      o += char(0x80 | (cp & 0x3F));
    } else {
      o += char(0xF0 | (cp >> 18));
      o += char(0x80 | ((cp >> 12) & 0x3F));
      o += char(0x80 | ((cp >> 6) & 0x3F));
      o += char(0x80 | (cp & 0x3F));
    }
  }
  unsigned hex4() {
    if (i_ + 4 > t_.size()) fail("short \\u escape");
    unsigned v = unsigned(std::stoul(t_.substr(i_, 4), nullptr, 16));
    i_ += 4;
    return v;
  }
  std::string str() {
    std::string o;
    ++i_;  // opening quote
    while (true) {
      if (i_ >= t_.size()) fail("unterminated string");
      char c = t_[i_++];
      if (c == '"') return o;
      if (c != '\\') {
        o += c;
        continue;
      }
      if (i_ >= t_.size()) fail("unterminated escape");
      char e = t_[i_++];
      switch (e) {
        case 'n': o += '\n'; break;
        case 't': o += '\t'; break;
        case 'r': o += '\r'; break;
        case 'b': o += '\b'; break;
        case 'f': o += '\f'; break;
        case 'u': {
          unsigned cp = hex4();
          if (cp >= 0xD800 && cp < 0xDC00 && lit("\\u")) cp = 0x10000 + ((cp - 0xD800) << 10) + (hex4() - 0xDC00);
          utf8(o, cp);
          break;
        }
        default: o += e;  // \" \\ \/
      }
    }
  }
  Json value(int depth) {
    if (depth > 64) fail("nested too deeply");
    ws();
    if (i_ >= t_.size()) fail("unexpected end");
    Json v;
    char c = t_[i_];
    if (c == '{') {
      v.kind = Json::Object;
      ++i_;
      ws();
      if (i_ < t_.size() && t_[i_] == '}') { ++i_; return v; }
      while (true) {
        ws();
        if (i_ >= t_.size() || t_[i_] != '"') fail("expected a key");
        std::string k = str();
        ws();
        if (i_ >= t_.size() || t_[i_] != ':') fail("expected ':'");
        ++i_;
        v.obj.emplace_back(std::move(k), value(depth + 1));
        ws();
        if (i_ < t_.size() && t_[i_] == ',') { ++i_; continue; }
        if (i_ < t_.size() && t_[i_] == '}') { ++i_; return v; }
        fail("expected ',' or '}'");
      }
    }
    if (c == '[') {
      v.kind = Json::Array;
      ++i_;
      ws();
      if (i_ < t_.size() && t_[i_] == ']') { ++i_; return v; }
      while (true) {
        v.arr.push_back(value(depth + 1));
        ws();
        if (i_ < t_.size() && t_[i_] == ',') { ++i_; continue; }
        if (i_ < t_.size() && t_[i_] == ']') { ++i_; return v; }
        fail("expected ',' or ']'");
      }
    }
    if (c == '"') {
      v.kind = Json::String;
      v.str = str();
      return v;
    }
    if (lit("true")) { v.kind = Json::Bool; v.b = true; return v; }
    if (lit("false")) { v.kind = Json::Bool; return v; }
    if (lit("null")) return v;
    const char* start = t_.c_str() + i_;
    char* end = nullptr;
    v.num = std::strtod(start, &end);
    if (end == start) fail("unexpected character");
    v.kind = Json::Number;
    i_ += size_t(end - start);
    return v;
  }
};

inline std::string quote(const std::string& s) {
  std::string o = "\"";
  for (unsigned char c : s) {
    if (c == '"') o += "\\\"";
    else if (c == '\\') o += "\\\\";
    else if (c == '\n' || c == '\r' || c == '\t') o += ' ';
    else if (c < 0x20) { char b[8]; std::snprintf(b, sizeof b, "\\u%04x", c); o += b; }
    else o += char(c);
  }
  return o + "\"";
}

inline std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// ---- what a peer gets and gives --------------------------------------------------------------

using Vec3 = std::array<double, 3>;

// The transfer function's points (contract section 3), already in s: colour and extinction tau
// (per unit normalised length) piecewise linear between points, constant beyond the ends.
struct TransferFunction {
  std::vector<double> s, tau;
  std::vector<Vec3> rgb;

  // Index i and weight t so that the value at x is (1 - t) v[i] + t v[i + 1].
  std::pair<size_t, double> locate(double x) const {
    if (s.size() < 2 || x <= s.front()) return {0, 0.0};
    if (x >= s.back()) return {s.size() - 2, 1.0};
    size_t i = size_t(std::upper_bound(s.begin(), s.end(), x) - s.begin()) - 1;
    return {i, (x - s[i]) / (s[i + 1] - s[i])};
  }
  double extinction(double x) const {
    if (s.size() == 1) return tau[0];
    auto [i, t] = locate(x);
    return (1 - t) * tau[i] + t * tau[i + 1];
  }
  Vec3 colour(double x) const {
    if (s.size() == 1) return rgb[0];
    auto [i, t] = locate(x);
    return {(1 - t) * rgb[i][0] + t * rgb[i + 1][0], (1 - t) * rgb[i][1] + t * rgb[i + 1][1],
            (1 - t) * rgb[i][2] + t * rgb[i + 1][2]};
  }
};

// prepare's scene, in the centred frame. positions: x y z per vertex; cells: 4 vertex indices
// per tet; scalars: the transfer function's s per vertex; diagonal: L (optical length = world
// length / L).
struct Scene {
  size_t vertices = 0, tets = 0;
  std::vector<double> positions;
  std::vector<uint32_t> cells;
  std::vector<double> scalars;
  double diagonal = 0;
  Vec3 bbox_min{}, bbox_max{};
  TransferFunction tf;
  std::string integrator;
  std::map<std::string, std::string> params;
};

struct Ray {
  Vec3 origin, dir;  // dir is unit length
};

// render's camera (contract section 2), centred frame. Matrices are row-major, OpenGL-style.
struct Camera {
  uint32_t width = 0, height = 0;
  std::string projection;  // "ortho" or "persp"
  Vec3 eye{}, target{}, up{}, right{}, forward{};
  double radius = 0, pixel_size = 0, ortho_scale = 0, fov_y_deg = 0, near = 0, far = 0;
  std::array<double, 16> view{}, proj{};

  // The ray through the centre of pixel (i, j): column i from the left, row j from the top.
  Ray ray(uint32_t i, uint32_t j) const {
    double x = (i + 0.5 - width / 2.0) * pixel_size, y = (height / 2.0 - j - 0.5) * pixel_size;
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = target[k] + x * right[k] + y * up[k];
    if (projection == "ortho") {
      Vec3 o;
      for (int k = 0; k < 3; ++k) o[k] = p[k] + eye[k] - target[k];
      return {o, forward};
    }
    Vec3 d{p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]};
    double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    return {eye, {d[0] / n, d[1] / n, d[2] / n}};
  }
};

// What render fills: rgba is width x height x 4 premultiplied linear RGBA, row 0 at the top
// (sized by serve before the call, zeroed). Times in ms; negative ones are not reported (a
// negative draw_ms becomes the time render took).
struct Frame {
  std::vector<float> rgba;
  double draw_ms = -1, project_ms = -1, sort_ms = -1, readback_ms = -1;
  long long gpu_bytes = -1;
  std::vector<std::pair<std::string, double>> counters;
};

struct Info {
  std::string name, version, family;  // family: "pt", "raycasting" or "other"
  std::vector<std::string> integrators;
  std::vector<std::string> projections{"ortho", "persp"};
  std::string device;  // optional, e.g. "cpu (g++ 12)"
};

class Peer {
 public:
  virtual ~Peer() = default;
  virtual Info info() = 0;
  virtual void prepare(const Scene& scene) = 0;
  virtual void render(const Camera& camera, Frame& frame) = 0;
  // Counters for the prepare reply (e.g. cells dropped).
  virtual std::vector<std::pair<std::string, double>> prepare_counters() { return {}; }
};

// ---- the protocol loop -----------------------------------------------------------------------

namespace detail {

template <class T>
std::vector<T> read_file(const std::string& path, size_t count) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open " + path);
  std::vector<T> v(count);
  f.read(reinterpret_cast<char*>(v.data()), std::streamsize(count * sizeof(T)));
  if (size_t(f.gcount()) != count * sizeof(T)) throw std::runtime_error(path + " is too short");
  return v;  // little-endian files on a little-endian machine
}

inline Vec3 vec3(const Json& j) {
  if (j.kind != Json::Array || j.arr.size() != 3) throw std::runtime_error("expected 3 numbers");
  return {j.arr[0].number(), j.arr[1].number(), j.arr[2].number()};
}

inline std::string strings(const std::vector<std::string>& v) {
  std::string o = "[";
  for (size_t i = 0; i < v.size(); ++i) o += (i ? "," : "") + quote(v[i]);
  return o + "]";
}

inline std::string counters(const std::vector<std::pair<std::string, double>>& c) {
  std::string o = "{";
  for (size_t i = 0; i < c.size(); ++i) o += (i ? "," : "") + quote(c[i].first) + ":" + number(c[i].second);
  return o + "}";
}

inline long long peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (long long)u.ru_maxrss * 1024;  // KiB on Linux
}

inline Scene scene(const Json& m) {
  Scene s;
  const Json& mesh = m.at("mesh");
  s.vertices = size_t(mesh.at("vertices").number());
  s.tets = size_t(mesh.at("tets").number());
  const Json& files = mesh.at("files");
  s.positions = read_file<double>(files.at("positions").string(), 3 * s.vertices);
  s.cells = read_file<uint32_t>(files.at("cells").string(), 4 * s.tets);
  s.scalars = read_file<double>(files.at("scalars").string(), s.vertices);
  s.diagonal = mesh.at("diagonal").number();
  s.bbox_min = vec3(mesh.at("bbox_min"));
  s.bbox_max = vec3(mesh.at("bbox_max"));
  for (auto& p : m.at("tf").at("points").arr) {
    s.tf.s.push_back(p.at("s").number());
    s.tf.tau.push_back(p.at("tau").number());
    s.tf.rgb.push_back(vec3(p.at("rgb")));
  }
  s.integrator = m.at("integrator").string();
  if (const Json* ps = m.find("params"))
    for (auto& kv : ps->obj) s.params[kv.first] = kv.second.string();
  return s;
}

inline Camera camera(const Json& m) {
  Camera c;
  c.width = uint32_t(m.at("width").number());
  c.height = uint32_t(m.at("height").number());
  c.projection = m.at("projection").string();
  c.eye = vec3(m.at("eye"));
  c.target = vec3(m.at("target"));
  c.up = vec3(m.at("up"));
  c.right = vec3(m.at("right"));
  c.forward = vec3(m.at("forward"));
  c.radius = m.at("radius").number();
  c.pixel_size = m.at("pixel_size").number();
  c.ortho_scale = m.at("ortho_scale").number();
  const Json& fov = m.at("fov_y_deg");
  c.fov_y_deg = fov.kind == Json::Number ? fov.num : 0.0;
  c.near = m.at("near").number();
  c.far = m.at("far").number();
  for (int k = 0; k < 16; ++k) {
    c.view[k] = m.at("view_matrix").arr.at(k).number();
    c.proj[k] = m.at("projection_matrix").arr.at(k).number();
  }
  return c;
}

inline std::string handle(Peer& peer, const Json& m, bool& bye) {
  const std::string& type = m.at("type").string();
  if (type == "bye") {
    bye = true;
    return "";
  }
  if (type == "hello") {
    std::string want = m.at("protocol").string();
    if (want.substr(0, want.find('.')) != "1")
      throw std::runtime_error("protocol " + want + " not supported (this peer speaks " + kProtocol + ")");
    Info i = peer.info();
    std::string o = ",\"protocol\":" + quote(kProtocol) + ",\"name\":" + quote(i.name) +
                    ",\"version\":" + quote(i.version) + ",\"family\":" + quote(i.family) +
                    ",\"integrators\":" + strings(i.integrators) + ",\"projections\":" + strings(i.projections);
    if (!i.device.empty()) o += ",\"device\":" + quote(i.device);
    return o;
  }
  if (type == "prepare") {
    Scene s = scene(m);
    Info i = peer.info();
    if (std::find(i.integrators.begin(), i.integrators.end(), s.integrator) == i.integrators.end())
      throw std::runtime_error("integrator " + s.integrator + " not supported");
    peer.prepare(s);
    return ",\"counters\":" + counters(peer.prepare_counters());
  }
  if (type == "render") {
    Camera c = camera(m);
    Info i = peer.info();
    if (std::find(i.projections.begin(), i.projections.end(), c.projection) == i.projections.end())
      throw std::runtime_error("projection " + c.projection + " not supported");
    Frame f;
    f.rgba.assign(size_t(c.width) * c.height * 4, 0.0f);
    auto t0 = std::chrono::steady_clock::now();
    peer.render(c, f);
    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (f.rgba.size() != size_t(c.width) * c.height * 4) throw std::runtime_error("Frame::rgba has the wrong size");
    std::string path = m.at("image").string();
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(f.rgba.data()), std::streamsize(f.rgba.size() * sizeof(float)));
    if (!out) throw std::runtime_error("cannot write " + path);
    std::string o = ",\"draw_ms\":" + number(f.draw_ms < 0 ? ms : f.draw_ms);
    if (f.project_ms >= 0) o += ",\"project_ms\":" + number(f.project_ms);
    if (f.sort_ms >= 0) o += ",\"sort_ms\":" + number(f.sort_ms);
    if (f.readback_ms >= 0) o += ",\"readback_ms\":" + number(f.readback_ms);
    if (f.gpu_bytes >= 0) o += ",\"gpu_bytes\":" + std::to_string(f.gpu_bytes);
    return o + ",\"counters\":" + counters(f.counters);
  }
  throw std::runtime_error("unknown request type " + type);
}

}  // namespace detail

// Answers tetbench's requests until `bye` or the end of stdin; returns the exit status.
inline int serve(Peer& peer) {
  int proto_fd = dup(1);
  dup2(2, 1);  // stray prints to stdout go to the log
  FILE* proto = fdopen(proto_fd, "w");
  if (!proto) return 1;
  std::string line;
  while (std::getline(std::cin, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    bool bye = false;
    std::string reply;
    try {
      Json m = JsonParser(line).parse();
      reply = "{\"ok\":true" + detail::handle(peer, m, bye);
    } catch (const std::exception& e) {
      std::cerr << "tetbench_peer: " << e.what() << std::endl;
      reply = "{\"ok\":false,\"error\":" + quote(e.what());
    }
    reply += ",\"peak_rss_bytes\":" + std::to_string(detail::peak_rss_bytes()) + "}\n";
    std::fputs(reply.c_str(), proto);
    std::fflush(proto);
    if (bye) break;
  }
  return 0;
}

}  // namespace tetbench
