// .npy reader (scenes/npy_io.h).
#include "scenes/npy_io.h"

#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <vector>

#include "core/error.h"
#include "core/input_file.h"
#include "core/limits.h"

namespace turbid {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicSize = 6;

// The header dict as NumPy writes it: {'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }
// Values are kept as their source text; only quoted strings, True/False and int tuples occur.
class HeaderParser {
 public:
  HeaderParser(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  std::map<std::string, std::string> Parse() {
    std::map<std::string, std::string> out;
    Expect('{');
    while (true) {
      SkipSpace();
      if (Peek() == '}') break;
      const std::string key = Quoted();
      Expect(':');
      SkipSpace();
      std::string value;
      if (Peek() == '\'' || Peek() == '"') {
        value = Quoted();
      } else if (Peek() == '(') {
        const size_t close = text_.find(')', at_);
        if (close == std::string::npos) Fail("unterminated shape tuple");
        value = text_.substr(at_, close + 1 - at_);
        at_ = close + 1;
      } else {
        const size_t start = at_;
        while (at_ < text_.size() && std::isalnum(static_cast<unsigned char>(text_[at_]))) ++at_;
        value = text_.substr(start, at_ - start);
      }
      if (out.count(key)) Fail("header repeats key '" + key + "'");
      out[key] = value;
      SkipSpace();
      if (Peek() == ',') ++at_;
    }
    return out;
  }

  // "(480, 640)" -> {480, 640}; "(5,)" -> {5}.
  std::vector<int64_t> Shape(const std::string& tuple) const {
    std::vector<int64_t> dims;
    std::string number;
    for (size_t i = 1; i + 1 < tuple.size(); ++i) {
      const char c = tuple[i];
      if (std::isdigit(static_cast<unsigned char>(c))) {
        number += c;
        if (number.size() > 12) Fail("shape entry too large in " + tuple);
      } else if (c == ',' || c == ' ') {
        if (c == ',') {
          if (number.empty()) Fail("bad shape " + tuple);
          dims.push_back(std::stoll(number));
          number.clear();
        }
      } else {
        Fail("bad shape " + tuple);
      }
    }
    if (!number.empty()) dims.push_back(std::stoll(number));
    return dims;
  }

  [[noreturn]] void Fail(const std::string& problem) const {
    throw Error(path_, "not a valid .npy header: " + problem);
  }

 private:
  char Peek() const { return at_ < text_.size() ? text_[at_] : '\0'; }
  void SkipSpace() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
  }
  void Expect(char c) {
    SkipSpace();
    if (Peek() != c) Fail(std::string("expected '") + c + "'");
    ++at_;
  }
  std::string Quoted() {
    SkipSpace();
    const char quote = Peek();
    if (quote != '\'' && quote != '"') Fail("expected a quoted key or string");
    const size_t close = text_.find(quote, at_ + 1);
    if (close == std::string::npos) Fail("unterminated string");
    std::string s = text_.substr(at_ + 1, close - at_ - 1);
    at_ = close + 1;
    return s;
  }

  const std::string& path_;
  const std::string& text_;
  size_t at_ = 0;
};

template <typename T>
void ConvertRows(const std::vector<char>& bytes, cv::Mat& out) {
  for (int y = 0; y < out.rows; ++y) {
    float* row = out.ptr<float>(y);
    for (int x = 0; x < out.cols; ++x) {
      T v;
      std::memcpy(&v, bytes.data() + (static_cast<size_t>(y) * out.cols + x) * sizeof(T),
                  sizeof(T));
      row[x] = static_cast<float>(v);
    }
  }
}

}  // namespace

bool IsNpyFile(const std::string& path) {
  if (!InputFileProblem(path).empty()) return false;  // never open a FIFO or device
  std::ifstream in(path, std::ios::binary);
  char head[kMagicSize] = {};
  if (!in.read(head, kMagicSize)) return false;
  return std::memcmp(head, kMagic, kMagicSize) == 0;
}

namespace {

// The preamble (magic, version, header length) and the header text of an open .npy file;
// *preamble_size is 10 (version 1) or 12 (versions 2 and 3).
std::string ReadNpyHeader(std::ifstream& in, const std::string& path, uintmax_t file_size,
                          size_t* preamble_size) {
  unsigned char preamble[12] = {};
  if (!in.read(reinterpret_cast<char*>(preamble), 10) ||
      std::memcmp(preamble, kMagic, kMagicSize) != 0)
    throw Error(path, "not a .npy file (no \\x93NUMPY magic)");
  const int major = preamble[6];
  uint64_t header_size = 0;
  *preamble_size = 10;
  if (major == 1) {
    header_size = preamble[8] | (uint64_t{preamble[9]} << 8);
  } else if (major == 2 || major == 3) {
    if (!in.read(reinterpret_cast<char*>(preamble) + 10, 2))
      throw Error(path, "truncated .npy header");
    header_size = preamble[8] | (uint64_t{preamble[9]} << 8) | (uint64_t{preamble[10]} << 16) |
                  (uint64_t{preamble[11]} << 24);
    *preamble_size = 12;
  } else {
    throw Error(path, ".npy format version " + std::to_string(major) + " is not supported (1-3)");
  }
  if (header_size > (1u << 20) || *preamble_size + header_size > file_size)
    throw Error(path, "truncated .npy header");
  std::string header(header_size, '\0');
  if (!in.read(header.data(), static_cast<std::streamsize>(header_size)))
    throw Error(path, "truncated .npy header");
  return header;
}

// The item size of a supported dtype ('<f4', '<f8', '<u2'); sets *integer for '<u2'.
size_t NpyItemSize(const std::string& path, const std::string& dtype, bool* integer) {
  if (dtype == "<f4") return 4;
  if (dtype == "<f8") return 8;
  if (dtype == "<u2") {
    *integer = true;
    return 2;
  }
  throw Error(path, "dtype '" + dtype +
                        "' is not supported (little-endian float32 '<f4', float64 '<f8' or "
                        "uint16 '<u2')");
}

// The (rows, cols) of a C-order 2-D array from the header's dict (its keys checked), checked
// against the size limits before anything is allocated.
std::vector<int64_t> NpyShape(const std::string& path, HeaderParser& parser,
                              const std::map<std::string, std::string>& dict) {
  if (dict.at("fortran_order") == "True")
    throw Error(path,
                "Fortran-order arrays are not supported (save a C-order array: "
                "numpy.ascontiguousarray)");
  if (dict.at("fortran_order") != "False") parser.Fail("fortran_order must be True or False");
  const std::vector<int64_t> shape = parser.Shape(dict.at("shape"));
  if (shape.size() != 2)
    throw Error(path, "array has " + std::to_string(shape.size()) + " dimensions " +
                          dict.at("shape") + ", a depth map must be 2-D (rows, cols)");
  if (shape[0] <= 0 || shape[1] <= 0)
    throw Error(path, "shape " + dict.at("shape") + " must have at least one row and column");
  CheckImageSize(path, shape[1], shape[0]);  // before the data size is computed or read
  return shape;
}

}  // namespace

NpyArray ReadNpy(const std::string& path) {
  static_assert(sizeof(float) == 4 && sizeof(double) == 8);
  const uint16_t probe = 1;
  uint8_t first_byte = 0;
  std::memcpy(&first_byte, &probe, 1);
  if (first_byte != 1) throw Error(path, ".npy reading needs a little-endian host");

  std::error_code ec;
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open for reading");
  const uintmax_t file_size = std::filesystem::file_size(path, ec);
  size_t preamble_size = 0;
  const std::string header = ReadNpyHeader(in, path, file_size, &preamble_size);
  HeaderParser parser(path, header);
  const std::map<std::string, std::string> dict = parser.Parse();
  for (const char* key : {"descr", "fortran_order", "shape"})
    if (!dict.count(key)) parser.Fail(std::string("missing key '") + key + "'");
  if (dict.size() != 3) parser.Fail("unexpected keys (expected descr, fortran_order, shape)");
  NpyArray out;
  out.dtype = dict.at("descr");
  const size_t item_size = NpyItemSize(path, out.dtype, &out.integer);
  const std::vector<int64_t> shape = NpyShape(path, parser, dict);
  const uint64_t data_size = static_cast<uint64_t>(shape[0] * shape[1]) * item_size;
  const uint64_t available = file_size - preamble_size - header.size();
  if (available != data_size)
    throw Error(path, "holds " + std::to_string(available) + " data bytes, shape " +
                          dict.at("shape") + " of " + out.dtype + " needs " +
                          std::to_string(data_size) +
                          (available < data_size ? " (truncated)" : ""));
  std::vector<char> bytes(data_size);
  if (!in.read(bytes.data(), static_cast<std::streamsize>(data_size)))
    throw Error(path, "truncated .npy data");
  out.values.create(static_cast<int>(shape[0]), static_cast<int>(shape[1]), CV_32FC1);
  if (item_size == 4) {
    ConvertRows<float>(bytes, out.values);
  } else if (item_size == 8) {
    ConvertRows<double>(bytes, out.values);
  } else {
    ConvertRows<uint16_t>(bytes, out.values);
  }
  return out;
}

}  // namespace turbid
