#include "ctcal/sensors/mrcal_model.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/spline/so3.h"

namespace ctcal {

namespace {

// The subset of Python literals a .cameramodel uses: dicts, lists/tuples, numbers, (byte)
// strings, True/False/None. Enough to skip any value mrcal writes, not a general Python parser.
struct PyValue {
  enum class Kind { kNumber, kString, kList, kDict, kConstant };
  Kind kind = Kind::kConstant;
  int line = 0;
  double number = 0.0;
  bool is_integer = false;
  std::string text;  // string value, or the constant's name
  std::vector<PyValue> items;
  std::vector<std::pair<std::string, PyValue>> entries;
};

std::string KindName(PyValue::Kind kind) {
  switch (kind) {
    case PyValue::Kind::kNumber:
      return "a number";
    case PyValue::Kind::kString:
      return "a string";
    case PyValue::Kind::kList:
      return "a list";
    case PyValue::Kind::kDict:
      return "a dict";
    case PyValue::Kind::kConstant:
      break;
  }
  return "a constant";
}

class PyLiteralParser {
 public:
  PyLiteralParser(const std::string& text, const std::string& source) : s_(text), source_(source) {}

  PyValue ParseDocument() {
    SkipSpace();
    PyValue v = ParseValue();
    SkipSpace();
    if (pos_ != s_.size())
      Fail("unexpected text after the closing '}'");
    return v;
  }

  [[noreturn]] void Fail(const std::string& what) const { FailAt(line_, what); }
  [[noreturn]] void FailAt(int line, const std::string& what) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line) + ": " + what);
  }

 private:
  char Peek() const { return pos_ < s_.size() ? s_[pos_] : '\0'; }
  char Get() {
    const char c = s_[pos_++];
    if (c == '\n')
      ++line_;
    return c;
  }

  void SkipSpace() {
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == '#') {
        while (pos_ < s_.size() && s_[pos_] != '\n')
          ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        Get();
      } else {
        break;
      }
    }
  }

  void Expect(char c) {
    SkipSpace();
    if (Peek() != c)
      Fail(std::string("expected '") + c + "'" + Found());
    Get();
  }

  std::string Found() const {
    if (pos_ >= s_.size())
      return ", found the end of the file";
    return std::string(", found '") + s_[pos_] + "'";
  }

  PyValue ParseValue() {
    SkipSpace();
    const char c = Peek();
    if (c == '{')
      return ParseDict();
    if (c == '[' || c == '(')
      return ParseList();
    if (c == '\'' || c == '"' || IsStringPrefix())
      return ParseStrings();
    if (c == '-' || c == '+' || c == '.' || std::isdigit(static_cast<unsigned char>(c)))
      return ParseNumber();
    if (std::isalpha(static_cast<unsigned char>(c)))
      return ParseConstant();
    Fail("expected a value" + Found());
  }

  // b'...', r"...", u'...' (any case, up to two prefix letters).
  bool IsStringPrefix() const {
    size_t p = pos_;
    for (int i = 0; i < 2 && p < s_.size() && std::strchr("bBrRuU", s_[p]) && s_[p] != '\0'; ++i) {
      ++p;
      if (p < s_.size() && (s_[p] == '\'' || s_[p] == '"'))
        return true;
    }
    return false;
  }

  PyValue ParseDict() {
    PyValue v;
    v.kind = PyValue::Kind::kDict;
    v.line = line_;
    Expect('{');
    for (;;) {
      SkipSpace();
      if (Peek() == '}') {
        Get();
        return v;
      }
      const int key_line = line_;
      PyValue key = ParseValue();
      if (key.kind != PyValue::Kind::kString)
        FailAt(key_line, "dict keys must be strings");
      for (const auto& e : v.entries)
        if (e.first == key.text)
          FailAt(key_line, "duplicate key '" + key.text + "'");
      Expect(':');
      v.entries.emplace_back(key.text, ParseValue());
      SkipSpace();
      if (Peek() == ',') {
        Get();
      } else if (Peek() != '}') {
        Fail("expected ',' or '}' in a dict" + Found());
      }
    }
  }

  PyValue ParseList() {
    PyValue v;
    v.kind = PyValue::Kind::kList;
    v.line = line_;
    const char close = Peek() == '[' ? ']' : ')';
    Get();
    for (;;) {
      SkipSpace();
      if (Peek() == close) {
        Get();
        return v;
      }
      v.items.push_back(ParseValue());
      SkipSpace();
      if (Peek() == ',') {
        Get();
      } else if (Peek() != close) {
        Fail(std::string("expected ',' or '") + close + "' in a list" + Found());
      }
    }
  }

  // One or more adjacent string literals, concatenated as Python does.
  PyValue ParseStrings() {
    PyValue v;
    v.kind = PyValue::Kind::kString;
    v.line = line_;
    do {
      while (Peek() != '\'' && Peek() != '"')
        Get();  // prefix letters
      const char quote = Get();
      for (;;) {
        if (pos_ >= s_.size() || Peek() == '\n')
          FailAt(v.line, "unterminated string");
        char c = Get();
        if (c == quote)
          break;
        if (c == '\\') {
          if (pos_ >= s_.size())
            FailAt(v.line, "unterminated string");
          c = Get();
          if (c == 'n')
            c = '\n';
          else if (c == 't')
            c = '\t';
        }
        v.text += c;
      }
      SkipSpace();
    } while (Peek() == '\'' || Peek() == '"' || IsStringPrefix());
    return v;
  }

  PyValue ParseNumber() {
    PyValue v;
    v.kind = PyValue::Kind::kNumber;
    v.line = line_;
    const size_t start = pos_;
    while (pos_ < s_.size() &&
           (std::isalnum(static_cast<unsigned char>(s_[pos_])) || std::strchr("+-._", s_[pos_])))
      ++pos_;
    std::string token = s_.substr(start, pos_ - start);
    token.erase(std::remove(token.begin(), token.end(), '_'), token.end());
    char* end = nullptr;
    v.number = std::strtod(token.c_str(), &end);
    if (token.empty() || end != token.c_str() + token.size() || !std::isfinite(v.number))
      FailAt(v.line, "'" + token + "' is not a finite number");
    v.is_integer = token.find_first_of(".eE") == std::string::npos;
    return v;
  }

  PyValue ParseConstant() {
    PyValue v;
    v.kind = PyValue::Kind::kConstant;
    v.line = line_;
    const size_t start = pos_;
    while (pos_ < s_.size() &&
           (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_'))
      ++pos_;
    v.text = s_.substr(start, pos_ - start);
    if (v.text != "True" && v.text != "False" && v.text != "None")
      FailAt(v.line, "unexpected word '" + v.text + "' (not a Python literal)");
    return v;
  }

  const std::string& s_;
  const std::string& source_;
  size_t pos_ = 0;
  int line_ = 1;
};

std::string FormatNumber(double x) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", x);
  return buf;
}

std::string JoinNumbers(const double* x, int n) {
  std::string out;
  for (int i = 0; i < n; ++i)
    out += (i ? ", " : "") + FormatNumber(x[i]);
  return out;
}

struct LensModelName {
  CameraModelType type;
  const char* mrcal_name;
};
constexpr LensModelName kShared[] = {
    {CameraModelType::kPinholeRadtan, "LENSMODEL_OPENCV4"},
    {CameraModelType::kPinholeNone, "LENSMODEL_PINHOLE"},
};
constexpr const char* kSharedList =
    "mrcal and ctcal share LENSMODEL_OPENCV4 (pinhole + radtan) and LENSMODEL_PINHOLE "
    "(pinhole + none)";

}  // namespace

std::string MrcalLensModelName(CameraModelType type) {
  for (const LensModelName& m : kShared)
    if (m.type == type)
      return m.mrcal_name;
  throw std::invalid_argument("camera model '" + CameraModelName(type) + "' with distortion '" +
                              DistortionModelName(type) + "' has no mrcal lens model (" +
                              kSharedList + ")");
}

CameraModelType FromMrcalLensModelName(const std::string& lensmodel) {
  for (const LensModelName& m : kShared)
    if (lensmodel == m.mrcal_name)
      return m.type;
  throw std::invalid_argument("mrcal lens model '" + lensmodel + "' has no ctcal camera model (" +
                              kSharedList + ")");
}

std::string EmitMrcalCameraModel(const CameraModel& camera, const MrcalRt& rt_cam_ref) {
  const std::string lensmodel =
      camera.mrcal_lens() ? camera.mrcal_lens()->name() : MrcalLensModelName(camera.type());
  std::ostringstream out;
  out << "# mrcal .cameramodel written by ctcal (" << camera.camera_model() << " + "
      << camera.distortion_model() << ")\n"
      << "{\n"
      << "    'lensmodel':  '" << lensmodel << "',\n\n"
      << "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n"
      << "    'intrinsics': [ " << JoinNumbers(camera.params().data(), camera.NumParams())
      << ",],\n\n"
      << "    # extrinsics are rt_fromref\n"
      << "    'extrinsics': [ " << JoinNumbers(rt_cam_ref.data(), 6) << ",],\n\n"
      << "    'imagersize': [ " << camera.width() << ", " << camera.height() << ",],\n"
      << "}\n";
  return out.str();
}

void SaveMrcalCameraModel(const std::string& path, const CameraModel& camera,
                          const MrcalRt& rt_cam_ref) {
  const std::string text = EmitMrcalCameraModel(camera, rt_cam_ref);
  std::ofstream file(path);
  if (!file)
    throw std::runtime_error(path + ": cannot open for writing");
  file << text;
  if (!file.flush())
    throw std::runtime_error(path + ": write failed");
}

MrcalCameraModel ParseMrcalCameraModel(const std::string& text, const std::string& source) {
  PyLiteralParser parser(text, source);
  const PyValue doc = parser.ParseDocument();
  if (doc.kind != PyValue::Kind::kDict)
    parser.FailAt(doc.line, "a .cameramodel is a dict {...}, found " + KindName(doc.kind));

  std::map<std::string, const PyValue*> keys;
  for (const auto& e : doc.entries)
    keys[e.first] = &e.second;
  for (const char* required : {"lensmodel", "intrinsics", "extrinsics", "imagersize"}) {
    if (!keys.count(required))
      parser.FailAt(doc.line, std::string("missing key '") + required +
                                  "' (a .cameramodel needs lensmodel, intrinsics, extrinsics, "
                                  "imagersize)");
  }

  const auto numbers = [&](const char* key, bool integers) {
    const PyValue& v = *keys.at(key);
    if (v.kind != PyValue::Kind::kList)
      parser.FailAt(v.line, std::string("'") + key + "' must be a list, found " + KindName(v.kind));
    std::vector<double> out;
    for (const PyValue& item : v.items) {
      if (item.kind != PyValue::Kind::kNumber || (integers && !item.is_integer))
        parser.FailAt(item.line, std::string("'") + key + "' must hold " +
                                     (integers ? "integers" : "numbers") + ", found " +
                                     KindName(item.kind));
      out.push_back(item.number);
    }
    return out;
  };

  const PyValue& lens = *keys.at("lensmodel");
  if (lens.kind != PyValue::Kind::kString)
    parser.FailAt(lens.line, "'lensmodel' must be a string, found " + KindName(lens.kind));
  // The two models SPEC section 4 shares with mrcal become ctcal's own; every other one an mrcal
  // camera (camera_model mrcal).
  std::shared_ptr<const MrcalLens> mrcal_lens;
  CameraModelType type = CameraModelType::kMrcal;
  try {
    type = FromMrcalLensModelName(lens.text);
  } catch (const std::invalid_argument&) {
    try {
      mrcal_lens = MrcalLens::FromName(lens.text);
    } catch (const std::invalid_argument& e) {
      parser.FailAt(lens.line, e.what());
    }
  }

  const std::vector<double> intrinsics = numbers("intrinsics", false);
  const std::vector<double> extrinsics = numbers("extrinsics", false);
  const std::vector<double> imagersize = numbers("imagersize", true);
  if (extrinsics.size() != 6)
    parser.FailAt(keys.at("extrinsics")->line,
                  "'extrinsics' must hold 6 numbers (rt_cam_ref), found " +
                      std::to_string(extrinsics.size()));
  if (imagersize.size() != 2)
    parser.FailAt(keys.at("imagersize")->line, "'imagersize' must be [width, height], found " +
                                                   std::to_string(imagersize.size()) + " numbers");
  try {
    const Eigen::Map<const Eigen::VectorXd> params(intrinsics.data(),
                                                   static_cast<Eigen::Index>(intrinsics.size()));
    const Eigen::Vector2i size(static_cast<int>(imagersize[0]), static_cast<int>(imagersize[1]));
    CameraModel camera =
        mrcal_lens ? CameraModel(mrcal_lens, params, size) : CameraModel(type, params, size);
    return MrcalCameraModel{camera, MrcalRt(extrinsics.data())};
  } catch (const std::invalid_argument& e) {
    parser.FailAt(keys.at("intrinsics")->line, "'" + lens.text + "': " + e.what());
  }
}

MrcalCameraModel LoadMrcalCameraModel(const std::string& path) {
  std::ifstream file(path);
  if (!file)
    throw std::runtime_error(path + ": cannot open");
  std::stringstream buffer;
  buffer << file.rdbuf();
  return ParseMrcalCameraModel(buffer.str(), path);
}

Eigen::Isometry3d TransformFromMrcalRt(const MrcalRt& rt_cam_ref) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = ExpSO3<double>(rt_cam_ref.head<3>()).toRotationMatrix();
  T.translation() = rt_cam_ref.tail<3>();
  return T;
}

MrcalRt MrcalRtFromTransform(const Eigen::Isometry3d& T_cam_ref) {
  MrcalRt rt;
  rt.head<3>() = LogSO3<double>(Eigen::Quaterniond(T_cam_ref.linear()));
  rt.tail<3>() = T_cam_ref.translation();
  return rt;
}

}  // namespace ctcal
