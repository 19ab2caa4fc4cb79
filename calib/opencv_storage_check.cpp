#include "calib/opencv_storage_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <string_view>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

constexpr size_t kMaxFlowDepth = 8;
constexpr size_t kMaxBlockDepth = 16;

bool is_key_start(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
bool is_key_char(char c) { return is_key_start(c) || (c >= '0' && c <= '9') || c == '.' || c == '-'; }
bool is_control(char c) { return (unsigned char)c < 0x20 || c == 0x7f; }

size_t line_of(const std::string& text, size_t at) {
  return 1 + size_t(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

// Anywhere, comments included: OpenCV's parsers read C strings and treat these bytes as ends.
void check_control_bytes(const std::string& path, const std::string& text, const char* format) {
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (is_control(c) && c != '\n' && c != '\r' && c != '\t')
      throw InputError(fmt::format("{}: line {}: a control byte 0x{:02x} (not the OpenCV {} a camera file holds)", path,
                                   line_of(text, i), (unsigned char)c, format));
  }
}

// One pass over the text, line by line; state that spans lines: the block levels above the
// current line and an open flow collection.
class Checker {
 public:
  Checker(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  void run() {
    size_t at = 0;
    while (at <= text_.size()) {
      size_t end = text_.find('\n', at);
      if (end == std::string::npos) end = text_.size();
      std::string_view line(text_.data() + at, end - at);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++line_no_;
      check_line(line);
      at = end + 1;
    }
    if (!flow_.empty()) fail("a '[' or '{' that is never closed");
  }

 private:
  enum class Expect { ItemOrClose, Item, Colon, Value, CommaOrClose };
  struct Flow {
    char open;
    Expect expect;
  };
  enum class Kind { Unknown, Keys, Items };
  struct Block {
    size_t indent;
    Kind kind;
  };

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("{}: line {}: {} (not the OpenCV YAML a camera file holds)", path_, line_no_, what));
  }

  void check_line(std::string_view line) {
    if (line_no_ == 1) {
      if (!(line.substr(0, 7) == "%YAML:1" || line.substr(0, 7) == "%YAML 1")) fail("the first line must be %YAML:1.0");
      return rest_is_comment(line, 7 + (line.size() > 7 && line[7] == '.' ? 1 : 0), true);
    }
    size_t i = line.find_first_not_of(' ');
    if (i == std::string_view::npos) return;  // blank
    if (!flow_.empty()) {                     // a collection continued from the lines above
      if (line[i] != '#' && i <= flow_indent_) fail("a continued '[' or '{' must be indented deeper than its key");
      return scan_flow(line, i);
    }
    if (line[i] == '\t') fail("a tab in the indentation (YAML indents with spaces)");
    if (line[i] == '#') return;
    const std::string_view content = line.substr(i);
    if (content.substr(0, 3) == "---" && i == 0 && !body_started_ && !marker_seen_) {
      marker_seen_ = true;
      return rest_is_comment(line, 3, false);
    }
    if (content[0] == '%') fail("a directive after the first line");
    if (content.substr(0, 3) == "---" || content.substr(0, 3) == "...") fail("a document marker inside the document");
    body_started_ = true;
    place_in_block(i);
    if (content[0] == '-' && (content.size() == 1 || content[1] == ' ')) return check_item(line, i);
    check_key(line, i);
  }

  // The line's indentation against the levels above it: deeper only under a "key:" that
  // opened a block, back only to a level used before.
  void place_in_block(size_t indent) {
    if (opened_block_ && !blocks_.empty() && indent > blocks_.back().indent) {
      if (blocks_.size() >= kMaxBlockDepth) fail("blocks nested deeper than 16 levels");
      blocks_.push_back({indent, Kind::Unknown});
    }
    opened_block_ = false;
    if (blocks_.empty()) blocks_.push_back({indent, Kind::Unknown});
    while (indent < blocks_.back().indent) {
      blocks_.pop_back();
      if (blocks_.empty()) fail("indented less than the first key");
    }
    if (indent != blocks_.back().indent) fail("indented deeper without a 'key:' above to hold it");
  }

  void set_kind(Kind kind) {
    Kind& level = blocks_.back().kind;
    if (level != Kind::Unknown && level != kind) fail("sequence items and keys mixed at one level");
    level = kind;
  }

  void check_item(std::string_view line, size_t i) {
    set_kind(Kind::Items);
    size_t v = line.find_first_not_of(' ', i + 1);
    if (v == std::string_view::npos || line[v] == '#') fail("an empty sequence item");
    size_t k = v;
    while (k < line.size() && is_key_char(line[k])) ++k;
    if (k > v && k < line.size() && line[k] == ':' && (k + 1 == line.size() || line[k + 1] == ' '))
      fail("a mapping inside a sequence item");
    check_value(line, v, i);
  }

  void check_key(std::string_view line, size_t i) {
    set_kind(Kind::Keys);
    if (line[i] == ':') fail("an empty key");
    if (!is_key_start(line[i])) fail(fmt::format("a key must start with a letter or '_', not '{}'", printable(line[i])));
    size_t p = i;
    while (p < line.size() && is_key_char(line[p])) ++p;
    if (p == line.size() || line[p] != ':') fail("a key must be followed directly by ':'");
    ++p;
    if (opens_block(line, p)) return;
    if (line[p] != ' ') fail("':' after a key must be followed by a space");
    p = line.find_first_not_of(' ', p);
    if (line.substr(p, 2) == "!!") {
      size_t t = p + 2;
      while (t < line.size() && is_key_char(line[t])) ++t;
      if (t == p + 2) fail("an empty '!!' tag");
      if (opens_block(line, t)) return;
      if (line[t] != ' ') fail("a '!!' tag must be followed by a space");
      p = line.find_first_not_of(' ', t);
    }
    check_value(line, p, i);
  }

  // Nothing but a comment after position p: the key holds the block on the lines below.
  bool opens_block(std::string_view line, size_t p) {
    const size_t q = line.find_first_not_of(' ', p);
    if (q != std::string_view::npos && line[q] != '#') return false;
    if (q != std::string_view::npos && q == p) fail("a comment must follow a space");
    opened_block_ = true;
    return true;
  }

  void check_value(std::string_view line, size_t p, size_t indent) {
    const char c = line[p];
    if (c == '[' || c == '{') {
      flow_indent_ = indent;
      return scan_flow(line, p);
    }
    if (c == '"' || c == '\'') return rest_is_comment(line, end_of_quote(line, p), false);
    if (std::string_view(",]}&*!|>%@`:?-#").find(c) != std::string_view::npos &&
        !(c == '-' && p + 1 < line.size() && line[p + 1] != ' '))
      fail(fmt::format("a value cannot start with '{}'", printable(c)));
    rest_is_comment(line, end_of_plain(line, p, ""), false);
  }

  // The end of a plain scalar starting at p: at a comment, or at one of `stops`.
  size_t end_of_plain(std::string_view line, size_t p, std::string_view stops) {
    for (; p < line.size(); ++p) {
      const char c = line[p];
      if (is_control(c)) fail("a control character in a value");
      if (c == '#' && (p == 0 || line[p - 1] == ' ')) return p;
      if (c == ':' && (p + 1 == line.size() || line[p + 1] == ' ')) fail("': ' inside a plain value (quote it)");
      if (c != ' ' && c != '#' && stops.find(c) != std::string_view::npos) return p;
    }
    return p;
  }

  size_t end_of_quote(std::string_view line, size_t p) {
    const char quote = line[p];
    for (size_t q = p + 1; q < line.size(); ++q) {
      if (is_control(line[q])) fail("a control character in a quoted string");
      if (quote == '"' && line[q] == '\\') {
        ++q;
      } else if (line[q] == quote) {
        return q + 1;
      }
    }
    fail("a quoted string that does not end on its line");
  }

  void rest_is_comment(std::string_view line, size_t p, bool header) {
    if (header) {  // "%YAML:1.0": the minor version's digits
      while (p < line.size() && line[p] >= '0' && line[p] <= '9') ++p;
    }
    const size_t q = line.find_first_not_of(' ', p);
    if (q == std::string_view::npos) return;
    if (line[q] != '#' || line[q - 1] != ' ') fail(fmt::format("unexpected '{}' after the value", printable(line[q])));
  }

  // A flow collection from p; its state carries over to the next line until it closes.
  void scan_flow(std::string_view line, size_t p) {
    while (p < line.size()) {
      const char c = line[p];
      if (c == ' ') {
        ++p;
        continue;
      }
      if (c == '#' && (p == 0 || line[p - 1] == ' ')) return;  // a comment to the end of the line
      if (is_control(c)) fail("a control character inside '[' or '{'");
      if (c == '[' || c == '{') {
        if (!flow_.empty()) {
          Flow& top = flow_.back();
          const bool item = top.open == '[' && (top.expect == Expect::ItemOrClose || top.expect == Expect::Item);
          if (!item && top.expect != Expect::Value) fail(fmt::format("'{}' out of place", c));
          top.expect = Expect::CommaOrClose;  // once the nested collection closes
        }
        if (flow_.size() >= kMaxFlowDepth) fail("'[' and '{' nested deeper than 8 levels");
        flow_.push_back({c, Expect::ItemOrClose});
        ++p;
      } else if (c == ']' || c == '}') {
        if (flow_.empty() || flow_.back().open != (c == ']' ? '[' : '{')) fail(fmt::format("an unmatched '{}'", c));
        const Expect e = flow_.back().expect;
        if (e == Expect::Item) fail(fmt::format("an empty item before '{}'", c));
        if (e == Expect::Colon || e == Expect::Value) fail("a key without a value");
        flow_.pop_back();
        ++p;
        if (flow_.empty()) return rest_is_comment(line, p, false);
      } else if (c == ',') {
        if (flow_.back().expect != Expect::CommaOrClose) fail("an empty item inside '[' or '{'");
        flow_.back().expect = Expect::Item;
        ++p;
      } else if (c == ':') {
        Flow& top = flow_.back();
        if (top.open != '{' || top.expect != Expect::Colon) fail(top.open == '{' ? "an empty key" : "':' inside '['");
        top.expect = Expect::Value;
        ++p;
      } else {
        p = scan_flow_scalar(line, p);
      }
    }
  }

  size_t scan_flow_scalar(std::string_view line, size_t p) {
    Flow& top = flow_.back();
    const bool key = top.open == '{' && (top.expect == Expect::ItemOrClose || top.expect == Expect::Item);
    const bool value = top.expect == Expect::Value ||
                       (top.open == '[' && (top.expect == Expect::ItemOrClose || top.expect == Expect::Item));
    if (!key && !value) fail(fmt::format("'{}' where ',' or a closing bracket belongs", printable(line[p])));
    size_t end;
    if (key) {
      if (!is_key_start(line[p])) fail(fmt::format("a key must start with a letter or '_', not '{}'", printable(line[p])));
      end = p;
      while (end < line.size() && is_key_char(line[end])) ++end;
      if (end == line.size() || line[end] != ':') fail("a key inside '{' must be followed directly by ':'");
      top.expect = Expect::Colon;
      return end;
    }
    if (line[p] == '"' || line[p] == '\'') {
      end = end_of_quote(line, p);
    } else {
      if (std::string_view("&*!|>%@`?").find(line[p]) != std::string_view::npos)
        fail(fmt::format("a value cannot start with '{}'", line[p]));
      end = end_of_plain(line, p, ",[]{}");
      if (end < line.size() && (line[end] == '[' || line[end] == '{')) fail("'[' or '{' inside a value");
    }
    top.expect = Expect::CommaOrClose;
    return end;
  }

  static std::string printable(char c) {
    return is_control(c) || (unsigned char)c >= 0x80 ? fmt::format("\\x{:02x}", (unsigned char)c) : std::string(1, c);
  }

  const std::string& path_;
  const std::string& text_;
  size_t line_no_ = 0;
  bool body_started_ = false, marker_seen_ = false, opened_block_ = false;
  std::vector<Block> blocks_;
  std::vector<Flow> flow_;
  size_t flow_indent_ = 0;  // the indentation of the line whose value opened the collection
};

// ---- XML ---------------------------------------------------------------------------------

class XmlChecker {
 public:
  XmlChecker(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  void run() {
    if (text_.compare(0, 5, "<?xml") != 0) fail(0, "the text must start with <?xml");
    at_ = 5;
    attributes("?>");
    skip_blanks_and_comments();
    if (!take("<opencv_storage>")) fail(at_, "the root element must be <opencv_storage>");
    content("opencv_storage", 1);
    skip_blanks_and_comments();
    if (at_ < text_.size()) fail(at_, "text after </opencv_storage>");
  }

 private:
  [[noreturn]] void fail(size_t at, const std::string& what) const {
    throw InputError(
        fmt::format("{}: line {}: {} (not the OpenCV XML a camera file holds)", path_, line_of(text_, at), what));
  }

  bool take(std::string_view s) {
    if (text_.compare(at_, s.size(), s) != 0) return false;
    at_ += s.size();
    return true;
  }
  void skip_blanks() {
    while (at_ < text_.size() && (text_[at_] == ' ' || text_[at_] == '\n' || text_[at_] == '\r' || text_[at_] == '\t'))
      ++at_;
  }
  void skip_blanks_and_comments() {
    while (true) {
      skip_blanks();
      if (!take("<!--")) return;
      const size_t end = text_.find("--", at_);
      if (end == std::string::npos || text_.compare(end, 3, "-->") != 0) fail(at_, "a comment not closed by -->");
      at_ = end + 3;
    }
  }
  std::string name() {
    const size_t start = at_;
    if (at_ >= text_.size() || !is_key_start(text_[at_])) fail(at_, "an element name must start with a letter or '_'");
    while (at_ < text_.size() && is_key_char(text_[at_])) ++at_;
    return text_.substr(start, at_ - start);
  }
  // name="value" pairs up to `close`.
  void attributes(std::string_view close) {
    while (true) {
      skip_blanks();
      if (take(close)) return;
      name();
      if (!take("=\"")) fail(at_, "an attribute must be name=\"value\"");
      const size_t end = text_.find('"', at_);
      if (end == std::string::npos) fail(at_, "an attribute value that is not closed");
      if (text_.find_first_of("<>&", at_) < end) fail(at_, "'<', '>' or '&' inside an attribute value");
      at_ = end + 1;
    }
  }
  // What is inside <parent> up to and including </parent>: text or elements.
  void content(const std::string& parent, int depth) {
    bool has_text = false, has_elements = false;
    while (true) {
      skip_blanks_and_comments();
      if (at_ >= text_.size()) fail(at_, "<" + parent + "> is never closed");
      if (take("</")) {
        const size_t at = at_;
        if (name() != parent) fail(at, "</" + text_.substr(at, at_ - at) + "> closes <" + parent + ">");
        skip_blanks();
        if (!take(">")) fail(at_, "'>' expected after </" + parent);
        return;
      }
      if (text_[at_] == '<') {
        if (has_text) fail(at_, "<" + parent + "> holds both text and elements");
        if (depth >= 16) fail(at_, "elements nested deeper than 16 levels");
        ++at_;
        const std::string child = name();
        attributes(">");
        content(child, depth + 1);
        has_elements = true;
        continue;
      }
      if (has_elements) fail(at_, "<" + parent + "> holds both elements and text");
      text();
      has_text = true;
    }
  }
  void text() {
    while (at_ < text_.size() && text_[at_] != '<') {
      if (text_[at_] == '>') fail(at_, "a '>' in text");
      if (text_[at_] == '&') {
        bool known = false;
        for (std::string_view entity : {"&lt;", "&gt;", "&amp;", "&quot;", "&apos;"})
          if (take(entity)) {
            known = true;
            break;
          }
        if (!known) fail(at_, "an entity other than &lt; &gt; &amp; &quot; &apos;");
        continue;
      }
      ++at_;
    }
  }

  const std::string& path_;
  const std::string& text_;
  size_t at_ = 0;
};

}  // namespace

void check_opencv_yaml_text(const std::string& path, const std::string& text) {
  check_control_bytes(path, text, "YAML");
  Checker(path, text).run();
}

void check_opencv_xml_text(const std::string& path, const std::string& text) {
  check_control_bytes(path, text, "XML");
  XmlChecker(path, text).run();
}

}  // namespace lp
