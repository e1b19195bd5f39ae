#pragma once
// Named per-element scalar attributes (scan id, f, f_g, f_s, density...), kept in insertion order
// so that files written and read back list them the same way. Each column has one value per element.
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace autoscan {

class ScalarAttributes {
 public:
  /// Adds or replaces column `name`. Contract: values.size() equals the element count of the owner.
  void set(std::string_view name, std::vector<double> values);
  /// Returns nullptr when the column does not exist.
  const std::vector<double>* find(std::string_view name) const;
  std::vector<double>* find(std::string_view name);
  /// Throws InputError naming the column when it does not exist.
  const std::vector<double>& get(std::string_view name) const;
  bool has(std::string_view name) const { return find(name) != nullptr; }
  void erase(std::string_view name);
  void clear() { columns_.clear(); }
  std::size_t size() const { return columns_.size(); }
  bool empty() const { return columns_.empty(); }
  const std::vector<std::pair<std::string, std::vector<double>>>& columns() const { return columns_; }
  std::vector<std::pair<std::string, std::vector<double>>>& columns() { return columns_; }

  /// Keeps the rows listed in `keep` (in that order) in every column.
  void select(const std::vector<std::size_t>& keep);
  /// Appends `other`'s rows (other has `other_rows` rows, this has `rows`). Columns missing on one
  /// side are filled with `fill`.
  void append(const ScalarAttributes& other, std::size_t rows, std::size_t other_rows, double fill = 0.0);

 private:
  std::vector<std::pair<std::string, std::vector<double>>> columns_;
};

}  // namespace autoscan
