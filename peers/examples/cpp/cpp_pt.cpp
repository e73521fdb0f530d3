// cpp-pt: projected tetrahedra on the CPU, as a tetbench peer written with the C++ SDK.
//
// Cells are sorted back to front by the depth of their centroids (the classic PT visibility
// order: exact for most cells of a convex mesh, approximate on non-convex ones and wherever
// centroids misorder neighbours) and projected one by one. For each pixel whose centre lies in
// a cell's projected bounding box, the ray is clipped against the cell's four face planes: the
// entry and exit give the segment's length and, through the scalar's linear gradient, its front
// and back `s`. The segment is composited over what lies behind it, `I <- I_seg + (1 - a) I`.
// Integrators (contract section 4): `average` (Shirley-Tuchman) and `partial` (Moreland-Angel,
// Psi by Gauss-Legendre quadrature).
//
// Build: g++ -O2 -std=c++17 -I peers/cpp peers/examples/cpp/cpp_pt.cpp -o peers/examples/cpp/build/cpp-pt
// Expected error against `reference`: docs/peers.md, "Example peers".

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>
#include <vector>

#include "tetbench_peer.hpp"

using tetbench::Vec3;

namespace {

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// Psi = integral over [0, 1] of exp(-a u - b u^2) du, by 8-point Gauss-Legendre on as many equal
// pieces as the exponent's slope needs (error well under 1e-9 for the exponents met here).
double psi(double a, double b) {
  static const double x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                              0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
  static const double w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                              0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  int pieces = std::clamp(int(std::fabs(a) + 2 * std::fabs(b)) / 4 + 1, 1, 256);
  double h = 1.0 / pieces, sum = 0;
  for (int p = 0; p < pieces; ++p)
    for (int k = 0; k < 8; ++k) {
      double u = h * (p + 0.5 * (x[k] + 1));
      sum += 0.5 * h * w[k] * std::exp(-a * u - b * u * u);
    }
  return sum;
}

struct Cell {
  std::array<Vec3, 4> n;  // face normals, pointing out (face k is opposite vertex k)
  std::array<bool, 4> claims;  // a ray inside face k's plane belongs to this cell
  std::array<double, 4> h;  // inside: n_k . x <= h_k
  Vec3 grad, v0, centroid;  // s(x) = s0 + grad . (x - v0)
  double s0;
};

class CppPt : public tetbench::Peer {
 public:
  tetbench::Info info() override {
    return {"cpp-pt", "1.0", "pt", {"average", "partial"}, {"ortho", "persp"}, "cpu (C++17, one thread)"};
  }

  void prepare(const tetbench::Scene& s) override {
    tf_ = s.tf;
    integrator_ = s.integrator;
    diagonal_ = s.diagonal;
    cells_.clear();
    verts_.clear();
    dropped_ = 0;
    auto vert = [&](uint32_t i) { return Vec3{s.positions[3 * i], s.positions[3 * i + 1], s.positions[3 * i + 2]}; };
    double eps = 1e-14 * s.diagonal * s.diagonal * s.diagonal;
    for (size_t t = 0; t < s.tets; ++t) {
      std::array<Vec3, 4> v;
      std::array<double, 4> sv;
      for (int k = 0; k < 4; ++k) {
        v[k] = vert(s.cells[4 * t + k]);
        sv[k] = s.scalars[s.cells[4 * t + k]];
      }
      Vec3 e1 = sub(v[1], v[0]), e2 = sub(v[2], v[0]), e3 = sub(v[3], v[0]);
      double det = dot(e1, cross(e2, e3));
      if (std::fabs(det) / 6 <= eps) {  // no volume, no optical depth
        ++dropped_;
        continue;
      }
      Cell c;
      for (int k = 0; k < 4; ++k) {
        const Vec3& a = v[(k + 1) % 4];
        Vec3 n = cross(sub(v[(k + 2) % 4], a), sub(v[(k + 3) % 4], a));
        if (dot(n, sub(v[k], a)) > 0) n = {-n[0], -n[1], -n[2]};
        c.n[k] = n;
        c.h[k] = dot(n, a);
        // Of the two cells sharing a face, the one whose outward normal is lexicographically
        // positive owns the rays inside the face's plane (each counted once).
        c.claims[k] = n[0] > 0 || (n[0] == 0 && (n[1] > 0 || (n[1] == 0 && n[2] > 0)));
      }
      // grad solves [e1 e2 e3]^T grad = ds (Cramer's rule).
      double d1 = sv[1] - sv[0], d2 = sv[2] - sv[0], d3 = sv[3] - sv[0];
      Vec3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
      for (int k = 0; k < 3; ++k) c.grad[k] = (d1 * c23[k] + d2 * c31[k] + d3 * c12[k]) / det;
      c.v0 = v[0];
      c.s0 = sv[0];
      for (int k = 0; k < 3; ++k) c.centroid[k] = 0.25 * (v[0][k] + v[1][k] + v[2][k] + v[3][k]);
      cells_.push_back(c);
      verts_.push_back(v);
    }
  }

  std::vector<std::pair<std::string, double>> prepare_counters() override { return {{"dropped_cells", double(dropped_)}}; }

  void render(const tetbench::Camera& cam, tetbench::Frame& f) override {
    auto t0 = std::chrono::steady_clock::now();
    // Back to front: the largest centroid depth first (ortho: along forward; persp: distance).
    std::vector<double> depth(cells_.size());
    for (size_t i = 0; i < cells_.size(); ++i) {
      Vec3 r = sub(cells_[i].centroid, cam.eye);
      depth[i] = cam.projection == "ortho" ? dot(r, cam.forward) : dot(r, r);
    }
    std::vector<uint32_t> order(cells_.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return depth[a] > depth[b]; });
    f.sort_ms = ms_since(t0);

    auto t1 = std::chrono::steady_clock::now();
    const double dist = std::sqrt(dot(sub(cam.target, cam.eye), sub(cam.target, cam.eye)));
    const uint32_t W = cam.width, H = cam.height;
    std::vector<double> acc(size_t(W) * H * 4, 0.0);  // composited in double, stored as float
    long long segments = 0;
    for (uint32_t ci : order) {
      const Cell& c = cells_[ci];
      // Projected bounding box in pixel coordinates (pixel centres at i, j).
      double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
      for (const Vec3& v : verts_[ci]) {
        Vec3 r = sub(v, cam.eye);
        double x = dot(r, cam.right), y = dot(r, cam.up);
        if (cam.projection != "ortho") {
          double s = dist / std::max(dot(r, cam.forward), 1e-30);
          x *= s;
          y *= s;
        }
        double px = x / cam.pixel_size + W / 2.0 - 0.5, py = H / 2.0 - 0.5 - y / cam.pixel_size;
        x0 = std::min(x0, px), x1 = std::max(x1, px), y0 = std::min(y0, py), y1 = std::max(y1, py);
      }
      int i0 = std::max(0, int(std::ceil(x0))), i1 = std::min(int(W) - 1, int(std::floor(x1)));
      int j0 = std::max(0, int(std::ceil(y0))), j1 = std::min(int(H) - 1, int(std::floor(y1)));
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          tetbench::Ray ray = cam.ray(uint32_t(i), uint32_t(j));
          double t_in = -1e300, t_out = 1e300;
          bool miss = false;
          for (int k = 0; k < 4 && !miss; ++k) {
            double den = dot(c.n[k], ray.dir), num = c.h[k] - dot(c.n[k], ray.origin);
            if (den > 0) t_out = std::min(t_out, num / den);
            else if (den < 0) t_in = std::max(t_in, num / den);
            else miss = num < 0 || (num == 0 && !c.claims[k]);
          }
          if (miss || !(t_in < t_out)) continue;
          ++segments;
          auto s_at = [&](double t) {
            Vec3 p{ray.origin[0] + t * ray.dir[0], ray.origin[1] + t * ray.dir[1], ray.origin[2] + t * ray.dir[2]};
            return c.s0 + dot(c.grad, sub(p, c.v0));
          };
          double sf = s_at(t_in), sb = s_at(t_out), l = (t_out - t_in) / diagonal_;
          double alpha;
          Vec3 col;
          if (integrator_ == "average") {
            double sm = 0.5 * (sf + sb);
            alpha = -std::expm1(-tf_.extinction(sm) * l);
            Vec3 cm = tf_.colour(sm);
            col = {cm[0] * alpha, cm[1] * alpha, cm[2] * alpha};
          } else {
            double tf_f = tf_.extinction(sf), tf_b = tf_.extinction(sb);
            double zeta = std::exp(-0.5 * l * (tf_f + tf_b));
            double ps = psi(tf_f * l, 0.5 * (tf_b - tf_f) * l);
            Vec3 cf = tf_.colour(sf), cb = tf_.colour(sb);
            alpha = 1 - zeta;
            for (int k = 0; k < 3; ++k) col[k] = cf[k] * (1 - ps) + cb[k] * (ps - zeta);
          }
          double* px = &acc[(size_t(j) * W + i) * 4];
          for (int k = 0; k < 3; ++k) px[k] = col[k] + (1 - alpha) * px[k];
          px[3] = alpha + (1 - alpha) * px[3];
        }
    }
    for (size_t k = 0; k < acc.size(); ++k) f.rgba[k] = float(acc[k]);
    f.draw_ms = ms_since(t1);
    f.counters = {{"segments", double(segments)}, {"dropped_cells", double(dropped_)}};
  }

 private:
  tetbench::TransferFunction tf_;
  std::string integrator_;
  double diagonal_ = 1;
  std::vector<Cell> cells_;
  std::vector<std::array<Vec3, 4>> verts_;
  size_t dropped_ = 0;
};

}  // namespace

int main() {
  CppPt peer;
  return tetbench::serve(peer);
}
