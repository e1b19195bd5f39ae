#include "autoscan/core/attributes.hpp"

#include "autoscan/core/error.hpp"

namespace autoscan {

void ScalarAttributes::set(std::string_view name, std::vector<double> values) {
  if (auto* col = find(name)) {
    *col = std::move(values);
    return;
  }
  columns_.emplace_back(std::string(name), std::move(values));
}

const std::vector<double>* ScalarAttributes::find(std::string_view name) const {
  for (const auto& [n, v] : columns_)
    if (n == name) return &v;
  return nullptr;
}

std::vector<double>* ScalarAttributes::find(std::string_view name) {
  for (auto& [n, v] : columns_)
    if (n == name) return &v;
  return nullptr;
}

const std::vector<double>& ScalarAttributes::get(std::string_view name) const {
  const auto* col = find(name);
  if (!col) throw InputError(fmt::format("missing scalar attribute '{}'", name));
  return *col;
}

void ScalarAttributes::erase(std::string_view name) {
  std::erase_if(columns_, [&](const auto& c) { return c.first == name; });
}

void ScalarAttributes::select(const std::vector<std::size_t>& keep) {
  for (auto& [n, v] : columns_) {
    std::vector<double> out;
    out.reserve(keep.size());
    for (auto i : keep) out.push_back(v.at(i));
    v = std::move(out);
  }
}

void ScalarAttributes::append(const ScalarAttributes& other, std::size_t rows, std::size_t other_rows,
                              double fill) {
  for (auto& [n, v] : columns_) {
    if (const auto* o = other.find(n)) {
      v.insert(v.end(), o->begin(), o->end());
    } else {
      v.resize(v.size() + other_rows, fill);
    }
  }
  for (const auto& [n, v] : other.columns()) {
    if (find(n)) continue;
    std::vector<double> col(rows, fill);
    col.insert(col.end(), v.begin(), v.end());
    columns_.emplace_back(n, std::move(col));
  }
}

}  // namespace autoscan
