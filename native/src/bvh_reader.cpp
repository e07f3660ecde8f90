// BVH reader: a hand-written tokenizer over the caller's buffer. Tokens are
// string_views into the text, numbers go through std::from_chars, and the
// joint hierarchy is walked with an explicit stack, so a hostile file can
// neither make us recurse nor allocate beyond BvhLimits.
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "motionkit/bvh.hpp"

namespace motionkit {
namespace {

// ---- Characters and numbers -------------------------------------------------

enum class CharClass : std::uint8_t { kOther, kBlank, kLineEnd, kBrace };

constexpr std::array<CharClass, 256> MakeCharClasses() {
  std::array<CharClass, 256> classes{};
  classes[' '] = classes['\t'] = classes['\v'] = classes['\f'] = CharClass::kBlank;
  classes['\r'] = classes['\n'] = CharClass::kLineEnd;
  classes['{'] = classes['}'] = CharClass::kBrace;
  return classes;
}
constexpr std::array<CharClass, 256> kCharClasses = MakeCharClasses();

inline CharClass ClassOf(char c) { return kCharClasses[static_cast<unsigned char>(c)]; }

// Whether a number ending at p ends its token (braces do not end values).
inline bool IsDelimiter(const char* p, const char* end) {
  return p == end || ClassOf(*p) == CharClass::kBlank || ClassOf(*p) == CharClass::kLineEnd;
}

enum class NumberStatus { kOk, kNotNumber, kOutOfRange, kNotFinite };

// Parses the number starting at p; *stop is where it ends, which the caller
// checks against its token's end. from_chars refuses a leading '+' (which
// some exporters write) and accepts "nan" and "inf" (which we refuse).
inline NumberStatus ParseNumber(const char* p, const char* end, double* value, const char** stop) {
  const char* first = p;
  if (first != end && *first == '+') {
    ++first;
    if (first != end && (*first == '-' || *first == '+')) {
      *stop = p;
      return NumberStatus::kNotNumber;
    }
  }
  const std::from_chars_result result = std::from_chars(first, end, *value);
  *stop = result.ptr;
  if (result.ec == std::errc::invalid_argument) {
    *stop = p;
    return NumberStatus::kNotNumber;
  }
  if (result.ec == std::errc::result_out_of_range) return NumberStatus::kOutOfRange;
  if (!std::isfinite(*value)) return NumberStatus::kNotFinite;
  return NumberStatus::kOk;
}

// Where a message points: 1-based line and column, the column in bytes.
struct Where {
  std::size_t line;
  std::size_t column;
};

enum class Saw { kToken, kLineEnd, kEndOfFile };

// Code units of the valid UTF-8 sequence starting at s[i], or 0. Messages
// quote file contents and must stay valid UTF-8 (Python decodes them).
std::size_t Utf8Length(std::string_view s, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char lead = byte(i);
  std::size_t length = 0;
  unsigned char low = 0x80, high = 0xBF;  // range of the first continuation byte
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) low = 0xA0;
    if (lead == 0xED) high = 0x9F;  // no surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) low = 0x90;
    if (lead == 0xF4) high = 0x8F;
  } else {
    return 0;
  }
  if (i + length > s.size()) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (std::size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

// Appends `text` for a message: at most 40 characters, control characters and
// invalid UTF-8 written as \xNN.
void AppendShown(std::string* out, std::string_view text) {
  constexpr std::size_t kMaxShown = 40;
  static const char kHex[] = "0123456789abcdef";
  std::size_t shown = 0;
  for (std::size_t i = 0; i < text.size(); ++shown) {
    if (shown == kMaxShown) {
      out->append("...");
      return;
    }
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7F) {
      out->push_back(static_cast<char>(c));
      ++i;
    } else if (const std::size_t length = Utf8Length(text, i); length != 0) {
      out->append(text.substr(i, length));
      i += length;
    } else {
      out->append("\\x");
      out->push_back(kHex[c >> 4]);
      out->push_back(kHex[c & 15]);
      ++i;
    }
  }
}

std::string Quoted(std::string_view text) {
  std::string out = "'";
  AppendShown(&out, text);
  out.push_back('\'');
  return out;
}

constexpr std::array<std::string_view, 6> kChannelNames = {"Xposition", "Yposition", "Zposition",
                                                           "Xrotation", "Yrotation", "Zrotation"};

class BvhParser {
 public:
  BvhParser(std::string_view text, std::string_view source, const BvhLimits& limits)
      : p_(text.data()),
        end_(text.data() + text.size()),
        line_start_(p_),
        source_(source),
        limits_(limits) {
    // A UTF-8 byte order mark, as some Windows tools write.
    if (text.substr(0, 3) == "\xEF\xBB\xBF") p_ += 3;
  }

  void Parse(Skeleton* skeleton, Motion* motion) {
    Next();
    if (token_ != "HIERARCHY") FailToken("expected HIERARCHY");
    ReadHierarchy();
    ReadMotion();
    skeleton->joints = std::move(joints_);
    skeleton->channel_count = channel_count_;
    motion->frame_time = frame_time_;
    motion->values.swap(values_);
  }

 private:
  // ---- Lexing ---------------------------------------------------------------

  Where Here(const char* p) const { return {line_, static_cast<std::size_t>(p - line_start_) + 1}; }

  // p_ is on a line end: step over it ("\r\n" is one) and count the line.
  void NewLine() {
    p_ += (*p_ == '\r' && p_ + 1 != end_ && p_[1] == '\n') ? 2 : 1;
    ++line_;
    line_start_ = p_;
  }

  void SkipBlanks() {
    while (p_ != end_ && ClassOf(*p_) == CharClass::kBlank) ++p_;
  }

  void SkipSpace() {
    while (p_ != end_) {
      const CharClass c = ClassOf(*p_);
      if (c == CharClass::kBlank) {
        ++p_;
      } else if (c == CharClass::kLineEnd) {
        NewLine();
      } else {
        break;
      }
    }
  }

  // End of the token starting at p: braces are tokens of their own.
  const char* TokenEnd(const char* p) const {
    if (p != end_ && ClassOf(*p) == CharClass::kBrace) return p + 1;
    while (p != end_ && ClassOf(*p) == CharClass::kOther) ++p;
    return p;
  }

  // The next token across line ends into token_ (empty at end of file).
  void Next() {
    SkipSpace();
    token_at_ = Here(p_);
    const char* start = p_;
    p_ = TokenEnd(p_);
    token_ = std::string_view(start, static_cast<std::size_t>(p_ - start));
  }

  // ---- Errors ---------------------------------------------------------------

  [[noreturn]] void Fail(Where at, std::string_view what, Saw saw,
                         std::string_view token = {}) const {
    std::string message(source_);
    message += ':' + std::to_string(at.line) + ':' + std::to_string(at.column) + ": ";
    message += what;
    switch (saw) {
      case Saw::kToken:
        message += " (saw ";
        message += Quoted(token);
        message += ')';
        break;
      case Saw::kLineEnd: message += " (saw end of line)"; break;
      case Saw::kEndOfFile: message += " (saw end of file)"; break;
    }
    throw Error(message);
  }

  // Fails on the token just read.
  [[noreturn]] void FailToken(std::string_view what) const {
    if (token_.empty()) Fail(token_at_, what, Saw::kEndOfFile);
    Fail(token_at_, what, Saw::kToken, token_);
  }

  // Fails on whatever is at p: a token, a line end or the end of the file.
  [[noreturn]] void FailAt(const char* p, std::string_view what) const {
    if (p == end_) Fail(Here(p), what, Saw::kEndOfFile);
    if (ClassOf(*p) == CharClass::kLineEnd) Fail(Here(p), what, Saw::kLineEnd);
    Fail(Here(p), what, Saw::kToken,
         std::string_view(p, static_cast<std::size_t>(TokenEnd(p) - p)));
  }

  // A joint as messages name it; one being read may not be in joints_ yet.
  std::string JointLabel(const Joint& joint) const {
    if (joint.end_site) {
      return "the End Site of " + Quoted(joints_[static_cast<std::size_t>(joint.parent)].name);
    }
    return "joint " + Quoted(joint.name);
  }
  std::string JointLabel(int index) const { return JointLabel(joints_[static_cast<std::size_t>(index)]); }

  // ---- Values ---------------------------------------------------------------

  // The current token as a finite double; `what` names it in messages.
  double NumberToken(std::string_view what) const {
    double value = 0.0;
    const char* stop = nullptr;
    const char* token_end = token_.data() + token_.size();
    NumberStatus status = ParseNumber(token_.data(), token_end, &value, &stop);
    if (stop != token_end) status = NumberStatus::kNotNumber;
    switch (status) {
      case NumberStatus::kOk: return value;
      case NumberStatus::kNotNumber: FailToken("expected a number for " + std::string(what));
      case NumberStatus::kOutOfRange:
        FailToken(std::string(what) + " is out of range for a double");
      case NumberStatus::kNotFinite: FailToken(std::string(what) + " is not finite");
    }
    FailToken("expected a number for " + std::string(what));
  }

  // The current token as a whole number (a leading '+' allowed); false when
  // it is not one. Out of range saturates, which every cap then rejects.
  bool IntegerToken(long long* value) const {
    const char* first = token_.data();
    const char* last = first + token_.size();
    if (first != last && *first == '+') {
      ++first;
      if (first != last && *first == '-') return false;
    }
    const auto result = std::from_chars(first, last, *value);
    if (result.ptr != last || result.ptr == first) return false;
    if (result.ec == std::errc::result_out_of_range) {
      *value = *first == '-' ? std::numeric_limits<long long>::min()
                             : std::numeric_limits<long long>::max();
    } else if (result.ec != std::errc()) {
      return false;
    }
    return true;
  }

  // ---- Hierarchy ------------------------------------------------------------

  // The rest of the keyword's line up to a brace: names may hold spaces
  // ("Bip01 L Thigh", as 3ds Max writes them).
  std::string_view ReadName(std::string_view keyword) {
    SkipBlanks();
    const char* start = p_;
    const char* last = p_;
    while (p_ != end_ && ClassOf(*p_) == CharClass::kOther) {
      p_ = TokenEnd(p_);
      last = p_;
      SkipBlanks();
    }
    if (last == start) FailAt(p_, "expected a joint name after " + std::string(keyword));
    p_ = last;
    return std::string_view(start, static_cast<std::size_t>(last - start));
  }

  void ReadChannels(Joint* joint) {
    Next();
    long long count = -1;
    if (!IntegerToken(&count) || count < 0 || count > kMaxChannelsPerJoint) {
      FailToken("expected a channel count from 0 to 6");
    }
    joint->channel_count = static_cast<int>(count);
    for (int c = 0; c < joint->channel_count; ++c) {
      Next();
      std::size_t type = 0;
      while (type < kChannelNames.size() && kChannelNames[type] != token_) ++type;
      if (type == kChannelNames.size()) {
        FailToken(token_.empty() ? "expected a channel name" : "unknown channel name");
      }
      joint->channels[static_cast<std::size_t>(c)] = static_cast<ChannelType>(type);
    }
  }

  // On ROOT, JOINT or End: reads the joint's header, OFFSET and CHANNELS,
  // pushes it on `open` and leaves the token after them in token_.
  void OpenJoint(int parent, std::vector<int>* open) {
    CheckRoomForJoint(open->size());
    Joint joint;
    joint.parent = parent;
    joint.end_site = token_ == "End";
    const int index = static_cast<int>(joints_.size());
    ReadJointName(index, &joint);
    ReadJointBody(&joint);
    joint.first_channel = channel_count_;
    channel_count_ += joint.channel_count;
    joints_.push_back(std::move(joint));
    open->push_back(index);
  }

  void CheckRoomForJoint(std::size_t depth) {
    if (static_cast<long long>(depth) > limits_.max_depth) {
      FailToken("joints nested deeper than limits.max_depth (" + std::to_string(limits_.max_depth) +
                ")");
    }
    if (static_cast<long long>(joints_.size()) >= limits_.max_joints) {
      FailToken("more joints than limits.max_joints (" + std::to_string(limits_.max_joints) + ")");
    }
  }

  // From the keyword on: the joint's name (an End Site's is its parent's with "_end"), registered as
  // joint `index`'s; a name another joint has is refused there.
  void ReadJointName(int index, Joint* joint) {
    const std::string_view keyword = token_;
    Where name_at = token_at_;
    std::string_view name_token = "End Site";
    if (joint->end_site) {
      Next();
      if (token_ != "Site") FailToken("expected 'Site' after 'End'");
      joint->name = joints_[static_cast<std::size_t>(joint->parent)].name + "_end";
    } else {
      SkipBlanks();
      name_at = Here(p_);
      name_token = ReadName(keyword);
      joint->name = std::string(name_token);
    }
    const auto [it, inserted] = names_.emplace(joint->name, index);
    if (!inserted) {
      std::string what = "duplicate joint name " + Quoted(joint->name);
      if (joints_[static_cast<std::size_t>(it->second)].end_site) {
        what += ", already given to " + JointLabel(it->second);
      }
      Fail(name_at, what, Saw::kToken, name_token);
    }
  }

  // After the name: '{', OFFSET and its three numbers, and a joint's CHANNELS; leaves the token after
  // them in token_.
  void ReadJointBody(Joint* joint) {
    Next();
    if (token_ != "{") FailToken("expected '{' to open " + JointLabel(*joint));
    Next();
    if (token_ != "OFFSET") FailToken("expected OFFSET in " + JointLabel(*joint));
    for (int axis = 0; axis < 3; ++axis) {
      Next();
      joint->offset[axis] = NumberToken("OFFSET");
    }
    Next();
    if (!joint->end_site && token_ == "CHANNELS") {
      ReadChannels(joint);
      Next();
    }
  }

  void ReadHierarchy() {
    std::vector<int> open;  // the blocks enclosing the current token, innermost last
    Next();
    for (;;) {
      if (open.empty()) {
        if (token_ == "ROOT") {
          OpenJoint(-1, &open);
          continue;
        }
        if (token_ == "MOTION" && !joints_.empty()) return;
        if (token_ == "}") FailToken("unbalanced '}': no joint is open");
        FailToken(joints_.empty() ? "expected ROOT" : "expected ROOT or MOTION");
      }
      const int top = open.back();
      if (token_ == "}") {
        open.pop_back();
        Next();
        continue;
      }
      const bool in_end_site = joints_[static_cast<std::size_t>(top)].end_site;
      if (!in_end_site && (token_ == "JOINT" || token_ == "End")) {
        OpenJoint(top, &open);
        continue;
      }
      // Only failures remain.
      const std::string label = JointLabel(top);
      if (in_end_site) FailToken("expected '}' to close " + label);
      if (token_ == "OFFSET") {
        FailToken("unexpected OFFSET in " + label + ": it comes once, right after '{'");
      }
      if (token_ == "CHANNELS") {
        FailToken("unexpected CHANNELS in " + label + ": they come once, right after OFFSET");
      }
      if (token_.empty() || token_ == "ROOT" || token_ == "MOTION" || token_ == "{") {
        FailToken("expected '}' to close " + label);
      }
      FailToken("unknown keyword in " + label);
    }
  }

  // ---- Motion ---------------------------------------------------------------

  void ReadMotion() {
    Next();
    if (token_ != "Frames:") FailToken("expected 'Frames:'");
    Next();
    const Where frames_at = token_at_;
    const std::string_view frames_token = token_;
    long long frames = 0;
    if (!IntegerToken(&frames)) FailToken("expected a frame count");
    if (frames < 0) FailToken("negative frame count");
    if (static_cast<unsigned long long>(frames) > limits_.max_frames) {
      FailToken("more frames than limits.max_frames (" + std::to_string(limits_.max_frames) + ")");
    }
    const auto channels = static_cast<std::size_t>(channel_count_);
    const auto frame_count = static_cast<std::size_t>(frames);
    if (channels != 0 && frame_count > limits_.max_values / channels) {
      FailToken(std::to_string(frames) + " frames of " + std::to_string(channels) +
                " channels are more values than limits.max_values (" +
                std::to_string(limits_.max_values) + ")");
    }
    Next();
    if (token_ != "Frame") FailToken("expected 'Frame Time:'");
    Next();
    if (token_ != "Time:") FailToken("expected 'Frame Time:'");
    Next();
    frame_time_ = NumberToken("the frame time");
    if (frame_time_ < 0.0) FailToken("negative frame time");
    SkipBlanks();
    if (p_ != end_ && ClassOf(*p_) != CharClass::kLineEnd) {
      FailAt(p_, "unexpected text after the frame time: frame rows start on the next line");
    }
    ReadRows(frame_count, channels, frames_at, frames_token);
    SkipSpace();
    if (p_ != end_) {
      double ignored = 0.0;
      const char* stop = nullptr;
      const bool numeric = ParseNumber(p_, end_, &ignored, &stop) != NumberStatus::kNotNumber &&
                           IsDelimiter(stop, end_);
      FailAt(p_, numeric ? "more frame rows than 'Frames: " + std::to_string(frames) + "' declares"
                         : std::string("unexpected text after the last frame"));
    }
  }

  // Frame rows are line-based: one frame's values fill one line.
  void ReadRows(std::size_t frames, std::size_t channels, Where frames_at,
                std::string_view frames_token) {
    if (channels == 0) {
      values_.resize(static_cast<Eigen::Index>(frames), 0);
      return;  // empty rows are indistinguishable from blank lines
    }
    // Allocate only what the rest of the file can hold (a value and a
    // separator take at least two bytes); a file claiming more is truncated,
    // and reading it into a scratch row finds where.
    const std::size_t total = frames * channels;
    const auto remaining = static_cast<std::size_t>(end_ - p_);
    const bool store = total <= remaining / 2 + 1;
    std::vector<double> scratch;
    if (store) {
      values_.resize(static_cast<Eigen::Index>(frames), static_cast<Eigen::Index>(channels));
    } else {
      scratch.resize(channels);
    }
    for (std::size_t f = 0; f < frames; ++f) {
      SkipSpace();
      if (p_ == end_) {
        Fail(Here(p_),
             "the file ends after " + std::to_string(f) + " of " + std::to_string(frames) +
                 " frames",
             Saw::kEndOfFile);
      }
      double* out = store ? values_.data() + f * channels : scratch.data();
      ReadRow(f, frames, channels, out);
    }
    if (!store) {
      // Unreachable: the file was too short for the rows it declared.
      Fail(frames_at, "internal error: frame rows fit in fewer bytes than possible", Saw::kToken,
           frames_token);
    }
  }

  // The hot loop: one pass per value, no token copies.
  void ReadRow(std::size_t frame, std::size_t frames, std::size_t channels, double* out) {
    const char* p = p_;
    for (std::size_t c = 0; c < channels; ++c) {
      while (p != end_ && ClassOf(*p) == CharClass::kBlank) ++p;
      if (p == end_ || ClassOf(*p) == CharClass::kLineEnd) {
        FailAt(p, RowLabel(frame, frames) + " has " + std::to_string(c) + " values, expected " +
                      std::to_string(channels));
      }
      const char* stop = nullptr;
      NumberStatus status = ParseNumber(p, end_, out + c, &stop);
      if (!IsDelimiter(stop, end_)) status = NumberStatus::kNotNumber;
      if (status != NumberStatus::kOk) FailValue(p, status, frame, frames, c);
      p = stop;
    }
    while (p != end_ && ClassOf(*p) == CharClass::kBlank) ++p;
    if (p != end_ && ClassOf(*p) != CharClass::kLineEnd) {
      std::size_t got = channels;
      for (const char* q = p; q != end_ && ClassOf(*q) != CharClass::kLineEnd; ++got) {
        while (q != end_ && ClassOf(*q) != CharClass::kBlank && ClassOf(*q) != CharClass::kLineEnd)
          ++q;
        while (q != end_ && ClassOf(*q) == CharClass::kBlank) ++q;
      }
      Fail(Here(p),
           RowLabel(frame, frames) + " has " + std::to_string(got) + " values, expected " +
               std::to_string(channels),
           Saw::kToken, std::string_view(p, static_cast<std::size_t>(RowTokenEnd(p) - p)));
    }
    p_ = p;
  }

  // In a row everything up to a blank or line end is one value.
  const char* RowTokenEnd(const char* p) const {
    while (p != end_ && ClassOf(*p) != CharClass::kBlank && ClassOf(*p) != CharClass::kLineEnd) ++p;
    return p;
  }

  static std::string RowLabel(std::size_t frame, std::size_t frames) {
    return "frame " + std::to_string(frame + 1) + " of " + std::to_string(frames);
  }

  [[noreturn]] void FailValue(const char* p, NumberStatus status, std::size_t frame,
                              std::size_t frames, std::size_t column) const {
    std::string what = RowLabel(frame, frames) + ", value " + std::to_string(column + 1) + ": ";
    switch (status) {
      case NumberStatus::kOutOfRange: what += "number out of range for a double"; break;
      case NumberStatus::kNotFinite: what += "value is not finite"; break;
      case NumberStatus::kNotNumber:
      case NumberStatus::kOk: what += "expected a number"; break;
    }
    Fail(Here(p), what, Saw::kToken,
         std::string_view(p, static_cast<std::size_t>(RowTokenEnd(p) - p)));
  }

  const char* p_;
  const char* end_;
  const char* line_start_;
  std::size_t line_ = 1;
  std::string_view token_;
  Where token_at_{1, 1};

  std::string_view source_;
  const BvhLimits& limits_;

  std::vector<Joint> joints_;
  std::unordered_map<std::string, int> names_;
  int channel_count_ = 0;
  double frame_time_ = 0.0;
  RowMatrixXd values_;
};

}  // namespace

void ReadBvh(std::string_view text, std::string_view source, Skeleton* skeleton, Motion* motion,
             const BvhLimits& limits) {
  if (skeleton == nullptr || motion == nullptr) {
    throw Error("ReadBvh: skeleton and motion must not be null");
  }
  // Parse into locals: on failure the caller's objects are left untouched.
  Skeleton parsed_skeleton;
  Motion parsed_motion;
  BvhParser(text, source, limits).Parse(&parsed_skeleton, &parsed_motion);
  *skeleton = std::move(parsed_skeleton);
  *motion = std::move(parsed_motion);
}

}  // namespace motionkit
