// The experiment file's external methods (docs/experiments.md, "External methods"), read through
// field tables (core/fields.h): each key is declared once, with its type, range and doc; an
// unknown key or a wrong type is one line naming the method and the key.
#include <map>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/fields.h"
#include "tools/harness/external_method.h"

namespace turbid {
namespace {

using nlohmann::json;

bool IsFloatFormat(const std::string& format) { return format == "pfm" || format == "exr"; }

// The files a command reads ("input") or writes ("output"); "" = not given.
struct FileSpec {
  std::string format;
  int bits = 0;
  std::string encoding;
};

// Every key an external method object may hold (which ones apply depends on its kind).
struct MethodKeys {
  std::string name, label;
  std::string python, results;
  std::vector<std::string> command;
  bool batch = false;
  int batch_size = 0;  // 0 = not given
  std::string encoding;
  bool has_input = false, has_output = false;
  FileSpec input, output;
  double timeout_s = 600.0;
  std::string cwd = ".";
  std::map<std::string, std::string> env;
};

std::string EncodingProblem(const json& v, std::string* out) {
  if (v.is_string() && (v == "srgb" || v == "linear")) {
    *out = v.get<std::string>();
    return "";
  }
  return "expected \"srgb\" or \"linear\", got " + fields_detail::ShownValue(v);
}

template <typename T>
void AddEncoding(Fields<T>& f, std::string T::*member, const std::string& doc) {
  f.Custom(
      "encoding", "one of: srgb, linear", "", doc,
      [member](const json& v, T& out) { return EncodingProblem(v, &(out.*member)); },
      [member](const T& in) -> json {
        if ((in.*member).empty()) return nullptr;
        return in.*member;
      });
}

const Fields<FileSpec>& FileSpecFields(bool input) {
  static const auto make = [](bool with_bits) {
    Fields<FileSpec> f;
    f.Custom(
        "format", "one of: png, pfm, exr", "", "file format",
        [](const json& v, FileSpec& out) -> std::string {
          if (v.is_string() && (v == "png" || v == "pfm" || v == "exr")) {
            out.format = v.get<std::string>();
            return "";
          }
          return "expected \"png\", \"pfm\" or \"exr\", got " + fields_detail::ShownValue(v);
        },
        [](const FileSpec& in) { return json(in.format); });
    if (with_bits) {
      f.Integer("bits", &FileSpec::bits, "bits per value: 8 or 16 for png, 32 for pfm/exr", 8, 32);
    }
    AddEncoding(f, &FileSpec::encoding, "how integer files are coded");
    return f;
  };
  static const Fields<FileSpec> in = make(true), out = make(false);
  return input ? in : out;
}

std::string CommandProblem(const json& v, std::vector<std::string>* out) {
  if (!v.is_array() || v.empty()) {
    return "must be a non-empty array of strings (the program and its arguments)";
  }
  out->clear();
  for (const json& arg : v) {
    if (!arg.is_string()) return "arguments must be strings, got " + fields_detail::ShownValue(arg);
    out->push_back(arg.get<std::string>());
  }
  if (out->front().empty()) return "names no program";
  return "";
}

std::string EnvProblem(const json& v, std::map<std::string, std::string>* out) {
  if (!v.is_object()) return "must be an object {NAME: \"value\"}";
  for (const auto& [name, value] : v.items()) {
    if (name.empty() || name.find('=') != std::string::npos) {
      return "name '" + name + "' is empty or holds '='";
    }
    if (!value.is_string()) return "value of " + name + " must be a string";
    (*out)[name] = value.get<std::string>();
  }
  return "";
}

// The table of one kind: "python", "results" or "command".
const Fields<MethodKeys>& KeysOf(const std::string& kind) {
  using M = MethodKeys;
  static const auto make = [](const std::string& k) {
    Fields<M> f;
    f.String("name", &M::name, "the method's name").String("label", &M::label, "its label");
    if (k == "python") {
      f.String("python", &M::python, "the key of the callable in turbid.sweep(methods=...)");
    } else if (k == "results") {
      f.String("results", &M::results, "a path pattern holding {id}");
    } else {
      f.Custom(
          "command", "array of strings", "", "the program and its arguments",
          [](const json& v, M& out) { return CommandProblem(v, &out.command); },
          [](const M& in) { return json(in.command); });
    }
    if (k != "results") {
      f.Boolean("batch", &M::batch, "one process / call per batch of items")
          .Integer("batch_size", &M::batch_size, "items per batch (batch methods only)", 1, 100000);
    }
    if (k != "command") {
      AddEncoding(f, &M::encoding, "how the method sees and answers images");
    } else {
      for (const bool input : {true, false}) {
        f.Custom(
            input ? "input" : "output", "object", "",
            input ? "the files it reads" : "the files it writes",
            [input](const json& v, M& out) -> std::string {
              FileSpec& spec = input ? out.input : out.output;
              (input ? out.has_input : out.has_output) = true;
              // Its errors name the key under it ("'input.format': ...").
              FileSpecFields(input).Read(v, &spec, "", input ? "input" : "output");
              return "";
            },
            [input](const M& in) {
              return FileSpecFields(input).ToJson(input ? in.input : in.output);
            });
      }
      f.Number("timeout_s", &M::timeout_s, "wall-clock limit, seconds",
               NumberRange::AboveUpTo(0.0, 604800.0))
          .String("cwd", &M::cwd, "working directory (relative to the experiment file)")
          .Custom(
              "env", "object", "", "environment variables added for the command",
              [](const json& v, M& out) { return EnvProblem(v, &out.env); },
              [](const M& in) { return json(in.env); });
    }
    return f;
  };
  static const Fields<M> python = make("python"), results = make("results"),
                         command = make("command");
  return kind == "python" ? python : kind == "results" ? results : command;
}

json BatchSpec(const MethodKeys& m, json spec) {
  if (m.batch_size != 0 && !m.batch) {
    throw Error("'batch_size' applies to \"batch\": true methods only");
  }
  spec["batch"] = m.batch;
  if (m.batch) spec["batch_size"] = m.batch_size != 0 ? m.batch_size : 32;
  return spec;
}

bool CommandHas(const std::vector<std::string>& command, const std::string& placeholder) {
  for (const std::string& arg : command) {
    if (arg.find(placeholder) != std::string::npos) return true;
  }
  return false;
}

// A per-image command names {input} and {output}; a batch command {input_dir} and {output_dir}.
void CheckPlaceholders(const std::vector<std::string>& command, bool batch) {
  const char* need_a = batch ? "{input_dir}" : "{input}";
  const char* need_b = batch ? "{output_dir}" : "{output}";
  const char* wrong_a = batch ? "{input}" : "{input_dir}";
  const char* wrong_b = batch ? "{output}" : "{output_dir}";
  for (const char* wrong : {wrong_a, wrong_b}) {
    if (CommandHas(command, wrong)) {
      throw Error(std::string("'command' holds ") + wrong + ", which " +
                  (batch ? "needs \"batch\": false" : "needs \"batch\": true"));
    }
  }
  for (const char* need : {need_a, need_b}) {
    if (!CommandHas(command, need)) {
      throw Error(std::string("'command' must contain ") + need +
                  (batch ? " (\"batch\": true: one process per batch of items)"
                         : " (\"batch\": false: one process per image)"));
    }
  }
}

// "input": {format, bits, encoding} with defaults by format (png: 8-bit sRGB; pfm/exr: 32-bit
// linear).
json InputSpec(const MethodKeys& m) {
  const std::string format = m.input.format.empty() ? "png" : m.input.format;
  const bool is_float = IsFloatFormat(format);
  json input = {
      {"format", format}, {"bits", is_float ? 32 : 8}, {"encoding", is_float ? "linear" : "srgb"}};
  if (m.input.bits != 0) {
    const bool ok = is_float ? m.input.bits == 32 : (m.input.bits == 8 || m.input.bits == 16);
    if (!ok) {
      throw Error(std::string("'input.bits' must be ") + (is_float ? "32" : "8 or 16") + " for " +
                  format + ", got " + std::to_string(m.input.bits));
    }
    input["bits"] = m.input.bits;
  }
  if (!m.input.encoding.empty()) {
    if (is_float && m.input.encoding != "linear") {
      throw Error("'input.encoding' of a float format (pfm, exr) must be \"linear\"");
    }
    input["encoding"] = m.input.encoding;
  }
  return input;
}

// "output": {format, encoding}; the encoding applies to integer files only (float files are
// linear); by default the method answers in the encoding it was given.
json OutputSpec(const MethodKeys& m, const json& input) {
  json output = {{"format", m.output.format.empty() ? input["format"] : json(m.output.format)},
                 {"encoding", IsFloatFormat(input["format"]) ? "srgb" : input["encoding"]}};
  if (!m.output.encoding.empty()) output["encoding"] = m.output.encoding;
  return output;
}

json CommandSpec(const MethodKeys& m) {
  if (m.command.empty()) throw Error("'command' must be a non-empty array of strings");
  CheckPlaceholders(m.command, m.batch);
  const json input = InputSpec(m);
  json spec = {{"kind", "command"},
               {"command", m.command},
               {"input", input},
               {"output", OutputSpec(m, input)}};
  spec["timeout_s"] = m.timeout_s;
  if (m.cwd.empty()) throw Error("'cwd' must be a non-empty path string");
  spec["cwd"] = m.cwd;
  spec["env"] = m.env;
  return BatchSpec(m, spec);
}

}  // namespace

json ParseExternalMethodSpec(const json& method) {
  const int kinds = static_cast<int>(method.contains("command")) +
                    static_cast<int>(method.contains("results")) +
                    static_cast<int>(method.contains("python"));
  if (kinds > 1) {
    throw Error(
        "give one of 'command' (a program to run), 'results' (precomputed files) or 'python' (a "
        "callable passed to turbid.sweep)");
  }
  const std::string kind = method.contains("python")    ? "python"
                           : method.contains("results") ? "results"
                                                        : "command";
  MethodKeys m;
  try {
    KeysOf(kind).Read(method, &m, "", "", "key");
  } catch (const Error& error) {
    // Fields names the source first ("<source>: ..."); the caller names the file and method.
    std::string what = error.what();
    if (what.rfind(": ", 0) == 0) what = what.substr(2);
    throw Error(what);
  }
  if (kind == "python") {
    if (m.python.empty()) {
      throw Error("'python' must be the key of the callable in turbid.sweep(..., methods={...})");
    }
    return BatchSpec(m, {{"kind", "python"},
                         {"python", m.python},
                         {"encoding", m.encoding.empty() ? "linear" : m.encoding}});
  }
  if (kind == "results") {
    if (m.results.find("{id}") == std::string::npos) {
      throw Error("'results' must be a path pattern holding {id}, e.g. \"results/x/{id}.png\"");
    }
    return {{"kind", "results"},
            {"results", m.results},
            {"encoding", m.encoding.empty() ? "srgb" : m.encoding}};
  }
  return CommandSpec(m);
}

}  // namespace turbid
