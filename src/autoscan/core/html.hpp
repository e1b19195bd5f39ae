#pragma once
// Text for HTML and SVG pages: the one escape function of the report and the SVG charts.
#include <string>
#include <string_view>

namespace autoscan {

/// `text` with the characters that are markup in HTML, SVG and their attribute values replaced by
/// entities: & < > " become &amp; &lt; &gt; &quot;; every other byte is copied (UTF-8 passes).
///
/// @param[in] text  any bytes
/// @return the escaped text, at least as long as `text`
std::string escape_html(std::string_view text);

}  // namespace autoscan
