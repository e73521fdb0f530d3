// null-cpp: a peer that draws nothing (a transparent image), to measure what the protocol
// itself costs per frame: the request and reply lines, and the image file written here and
// read by tetbench (docs/peers.md, "Overhead").
//
// Build: make -C peers/examples/cpp

#include "tetbench_peer.hpp"

namespace {

class NullPeer : public tetbench::Peer {
 public:
  tetbench::Info info() override {
    return {"null-cpp", "1.0", "other", {"average", "partial", "preint", "exact"}, {"ortho", "persp"}, "none"};
  }
  void prepare(const tetbench::Scene&) override {}
  void render(const tetbench::Camera&, tetbench::Frame& f) override { f.draw_ms = 0; }
};

}  // namespace

int main() {
  NullPeer peer;
  return tetbench::serve(peer);
}
