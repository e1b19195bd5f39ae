// Fuzz target for the pose parser of the command line (--pose, --from): "px,py,pz,dx,dy,dz[,ux,uy,uz]"
// or a JSON object (core/pose.hpp). An accepted pose must be finite, within kMaxCoordinate, with a
// usable direction (normalized() must not throw).
#include <cstdlib>

#include "autoscan/core/pose.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  autoscan::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = autoscan::fuzz::bytes_of(data, size);
  autoscan::fuzz::expect_input_error([&] {
    const autoscan::Pose p = autoscan::parse_pose(text, "--pose");
    for (const auto* v : {&p.position, &p.direction, &p.up})
      if (!v->allFinite() || v->cwiseAbs().maxCoeff() > autoscan::kMaxCoordinate) std::abort();
    const autoscan::Pose n = p.normalized();
    if (!n.direction.allFinite() || !n.up.allFinite()) std::abort();
  });
  return 0;
}
