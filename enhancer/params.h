// A method's parameters declared once (core/fields.h): the field table of its Options struct
// drives the strict reading of the caller's JSON overrides, `turbid enhance --list`,
// turbid.methods() and the parameter tables of docs/methods.md.
//
//   const Fields<DcpOptions>& DcpFields() {
//     static const Fields<DcpOptions> fields = Fields<DcpOptions>()
//         .Integer("patch_size", &DcpOptions::patch_size, "window side, pixels, odd >= 1")
//         .Tag(static_cast<int>(SizeBound::kWindow))
//         .Number("omega", &DcpOptions::omega, "fraction of haze removed, (0,1]");
//     return fields;
//   }
//   e.info.params = MethodParamsOf(DcpFields());
//   e.run = [](const json& params, const EnhanceInput& in) {
//     return DarkChannelPrior(ReadMethodParams("dcp", params, DcpFields()), in.image);
//   };
//
// Errors name the method and key: "dcp: parameter 'omega': expected a number, got \"x\"",
// "dcp: unknown parameter 'x' (known: ...)"; then Options::Check's "dcp: <why>".
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/fields.h"
#include "enhancer/registry.h"

namespace turbid {

// `options` with the caller's overrides applied (strictly), then checked (Options::Check).
template <typename Options>
Options ReadMethodParams(const std::string& method, const nlohmann::json& params,
                         const Fields<Options>& fields, Options options = Options{}) {
  if (!params.is_null() && !params.is_object()) {
    throw Error(method + ": parameters must be a JSON object, got " + fields_detail::ShownValue(params));
  }
  fields.Read(params, &options, method, "", "parameter");
  std::string why;
  if (!options.Check(&why)) throw Error(method + ": " + why);
  return options;
}

// MethodInfo::params from the table: name, default (from `defaults`), doc, size bound (the tag).
template <typename Options>
std::vector<MethodParam> MethodParamsOf(const Fields<Options>& fields,
                                        const Options& defaults = Options{}) {
  std::vector<MethodParam> out;
  for (const FieldInfo& f : fields.Info(defaults)) {
    out.push_back(MethodParam{f.key, f.default_value, f.doc, static_cast<SizeBound>(f.tag)});
  }
  return out;
}

}  // namespace turbid
