// The parameter tables (parameter_table.hpp) in the packages' pybind11 modules: a struct's
// fields as Python attributes under their YAML names, a dict read into a struct, and the table
// itself as a list of dicts (the export check_config's schema and the README tables are
// generated from: scripts/export_parameters). Included by the bindings only (needs pybind11).
#pragma once

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "laserscan_common/parameter_table.hpp"

namespace laserscan_common
{
namespace python
{
namespace py = pybind11;

/// Every field of P's table as a read-write attribute of the Python class.
template <class P, class... Options>
void bindFields(py::class_<P, Options...>& cls)
{
  const P defaults;
  visitFields(defaults, [&cls](const auto& field, const ParamInfo& info) {
    using T = std::decay_t<decltype(field)>;
    const std::string name = info.name;
    cls.def_property(
      info.name,
      [name](const P& p) {
        T out{};
        visitFields(p, [&](const auto& f, const ParamInfo& i) {
          if constexpr (std::is_same_v<std::decay_t<decltype(f)>, T>)
            if (name == i.name)
              out = f;
        });
        return out;
      },
      [name](P& p, const T& value) {
        visitFields(p, [&](auto& f, const ParamInfo& i) {
          if constexpr (std::is_same_v<std::decay_t<decltype(f)>, T>)
            if (name == i.name)
              f = value;
        });
      },
      info.meaning);
  });
}

/// The fields of P that `d` names (other keys are left alone).
template <class P>
P fromDict(const py::dict& d)
{
  P p;
  visitFields(p, [&d](auto& field, const ParamInfo& info) {
    if (d.contains(info.name))
      field = d[info.name].template cast<std::decay_t<decltype(field)>>();
  });
  return p;
}

/// P's table: one dict per field (name, type, unit, default, lo, hi, lo_open, finite,
/// nonempty, frame_id, angle, default_text, meaning), defaults from a default-constructed P.
template <class P>
py::list table()
{
  py::list out;
  const P defaults;
  visitFields(defaults, [&out](const auto& field, const ParamInfo& info) {
    py::dict d;
    d["name"] = info.name;
    d["type"] = typeName(field);
    d["unit"] = info.unit;
    d["default"] = py::cast(field);
    d["lo"] = info.lo;
    d["hi"] = info.hi;
    d["lo_open"] = info.lo_open;
    d["finite"] = info.finite;
    d["nonempty"] = info.nonempty;
    d["frame_id"] = info.frame_id;
    d["angle"] = info.angle;
    d["default_text"] = info.default_text;
    d["meaning"] = info.meaning;
    out.append(d);
  });
  return out;
}

}  // namespace python
}  // namespace laserscan_common
