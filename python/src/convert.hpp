#pragma once
// Conversions between Python objects and the library's types, shared by the binding translation
// unit (docs/python.md explains the rules):
//  * options: a Python dict becomes an nlohmann::json and goes through the library's own JSON
//    readers, so the Python options are exactly the documented JSON schema;
//  * point arrays: (N, 3) float64 C-contiguous NumPy arrays share memory with std::vector<Vec3>
//    (Eigen's Vector3d is three packed doubles); see views() and copy_rows().
#include <fmt/ranges.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autoscan/core/error.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::python {

namespace py = pybind11;

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
static_assert(sizeof(Tri) == 3 * sizeof(int), "Tri must be three packed ints");
static_assert(sizeof(Rgb) == 3, "Rgb must be three packed bytes");

/// Python object (dict, list, str, int, float, bool, None, NumPy scalars and arrays) to JSON.
/// Throws InputError naming `what` and the key path for anything else.
nlohmann::json to_json(py::handle obj, const std::string& what);
/// JSON to Python (dict, list, str, int, float, bool, None).
py::object from_json(const nlohmann::json& j);

/// The element type of a packed 3-column row: Vec3 -> double, Tri -> int, Rgb -> uint8.
template <class Row>
struct RowScalar;
template <>
struct RowScalar<Vec3> {
  using type = double;
};
template <>
struct RowScalar<Vec3f> {
  using type = float;
};
template <>
struct RowScalar<Tri> {
  using type = int;
};
template <>
struct RowScalar<Rgb> {
  using type = std::uint8_t;
};

/// A writable (N, 3) NumPy view of `rows` that keeps `owner` (the Python object holding the vector)
/// alive. No copy. Empty columns give a fresh (0, 3) array.
template <class Row>
py::array rows_view(std::vector<Row>& rows, py::handle owner) {
  using T = typename RowScalar<Row>::type;
  const auto n = static_cast<py::ssize_t>(rows.size());
  if (rows.empty()) return py::array_t<T>(std::vector<py::ssize_t>{0, 3});
  return py::array_t<T>({n, py::ssize_t(3)}, {py::ssize_t(sizeof(Row)), py::ssize_t(sizeof(T))},
                        reinterpret_cast<T*>(rows.data()), owner);
}

/// A writable (N,) view of a scalar column, keeping `owner` alive. No copy.
template <class T>
py::array column_view(std::vector<T>& values, py::handle owner) {
  if (values.empty()) return py::array_t<T>(py::ssize_t(0));
  return py::array_t<T>({static_cast<py::ssize_t>(values.size())}, {py::ssize_t(sizeof(T))}, values.data(), owner);
}

/// Hands a vector over to NumPy without copying: the array owns the moved vector (a capsule frees it).
template <class T>
py::array take_column(std::vector<T>&& values, std::vector<py::ssize_t> shape = {}) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule capsule(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  if (shape.empty()) shape = {static_cast<py::ssize_t>(owned->size())};
  return py::array_t<T>(shape, owned->data(), capsule);
}
template <class Row>
py::array take_rows(std::vector<Row>&& rows) {
  using T = typename RowScalar<Row>::type;
  auto* owned = new std::vector<Row>(std::move(rows));
  py::capsule capsule(owned, [](void* p) { delete static_cast<std::vector<Row>*>(p); });
  return py::array_t<T>({static_cast<py::ssize_t>(owned->size()), py::ssize_t(3)},
                        {py::ssize_t(sizeof(Row)), py::ssize_t(sizeof(T))}, reinterpret_cast<T*>(owned->data()),
                        capsule);
}

/// The array `obj` as a C-contiguous array of T (a view when it already is one, else converted).
/// Throws InputError naming `what` when it cannot be converted.
template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> as_array(py::handle obj, const std::string& what) {
  auto a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a) {
    PyErr_Clear();
    throw InputError(fmt::format("{}: expected a numeric array, got {}", what,
                                 std::string(py::str(py::type::handle_of(obj).attr("__name__")))));
  }
  return a;
}

/// Checks that `a` has shape (rows, 3) (rows = -1: any) and returns its row count.
inline std::size_t check_rows3(const py::array& a, long rows, const std::string& what) {
  const bool ok = a.ndim() == 2 && a.shape(1) == 3 && (rows < 0 || a.shape(0) == rows);
  if (!ok) {
    const std::vector<py::ssize_t> dims(a.shape(), a.shape() + a.ndim());
    const std::string shape = fmt::format("({}{})", fmt::join(dims, ", "), a.ndim() == 1 ? "," : "");
    throw InputError(rows < 0 ? fmt::format("{}: expected an array of shape (N, 3), got {}", what, shape)
                              : fmt::format("{}: expected an array of shape ({}, 3), got {}", what, rows, shape));
  }
  return static_cast<std::size_t>(a.shape(0));
}

/// Copies an (N, 3) array into `rows`. When `rows` already has N rows they are overwritten in place
/// (its buffer, and so every NumPy view of it, stays valid); an empty column is allocated.
template <class Row>
void copy_rows(std::vector<Row>& rows, py::handle obj, long expected, const std::string& what) {
  using T = typename RowScalar<Row>::type;
  const auto a = as_array<T>(obj, what);
  const std::size_t n = check_rows3(a, expected, what);
  if (rows.size() != n) {
    AUTOSCAN_CHECK(rows.empty(), "{}: cannot resize a column that NumPy views may share", what);
    rows.resize(n);
  }
  if (n) std::memcpy(static_cast<void*>(rows.data()), a.data(), n * sizeof(Row));
}

}  // namespace autoscan::python
