#pragma once
// Progress and cancellation for long stages (docs/conventions.md; CGAL's callback): a stage calls
// `report(fraction)` now and then; the callback returns false to ask the stage to stop, in which
// case the stage throws Cancelled. Callbacks may be called from worker threads but never
// concurrently (Progress serialises them).
#include <functional>
#include <mutex>
#include <string>
#include <string_view>

#include "autoscan/core/error.hpp"

namespace autoscan {

using ProgressCallback = std::function<bool(std::string_view stage, double fraction)>;

class Cancelled : public RuntimeError {
 public:
  explicit Cancelled(std::string_view stage) : RuntimeError(fmt::format("{}: cancelled", stage)) {}
};

class Progress {
 public:
  Progress(ProgressCallback cb, std::string stage) : cb_(std::move(cb)), stage_(std::move(stage)) {}
  /// Reports `fraction` in [0, 1]; throws Cancelled if the callback says stop.
  void report(double fraction) {
    if (!cb_) return;
    std::lock_guard lock(m_);
    if (!cb_(stage_, fraction)) throw Cancelled(stage_);
  }

 private:
  ProgressCallback cb_;
  std::string stage_;
  std::mutex m_;
};

}  // namespace autoscan
