// The report viewer's JavaScript bundle, embedded at build time (see CMakeLists.txt).
#include "autoscan/report/bundle.hpp"

#ifdef AUTOSCAN_VIEWER_BUNDLE
asm(".section .rodata\n"
    ".balign 16\n"
    ".global autoscan_viewer_bundle_begin\n"
    "autoscan_viewer_bundle_begin:\n"
    ".incbin \"" AUTOSCAN_VIEWER_BUNDLE "\"\n"
    ".global autoscan_viewer_bundle_end\n"
    "autoscan_viewer_bundle_end:\n"
    ".byte 0\n"
    ".previous\n");
extern "C" const char autoscan_viewer_bundle_begin[];
extern "C" const char autoscan_viewer_bundle_end[];
#endif

namespace autoscan::report {

std::string_view viewer_bundle() {
#ifdef AUTOSCAN_VIEWER_BUNDLE
  return {autoscan_viewer_bundle_begin,
          static_cast<std::size_t>(autoscan_viewer_bundle_end - autoscan_viewer_bundle_begin)};
#else
  return {};
#endif
}

}  // namespace autoscan::report
