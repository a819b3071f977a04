#include "python_literal.hpp"

#include <cctype>
#include <charconv>
#include <limits>
#include <string>

#include "document.hpp"
#include "fishcam/core/error.hpp"

namespace fishcam::detail {
namespace {

class Parser {
 public:
  explicit Parser(std::string_view text) : s_(text) {}

  nlohmann::json document() {
    nlohmann::json value = parse_value();
    skip_space();
    if (pos_ != s_.size()) fail("unexpected text after the end of the value");
    return value;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    int line = 1;
    for (size_t i = 0; i < pos_ && i < s_.size(); ++i) line += s_[i] == '\n';
    throw Error("line " + std::to_string(line) + ": " + what);
  }

  void skip_space() {
    while (pos_ < s_.size()) {
      if (std::isspace(static_cast<unsigned char>(s_[pos_]))) {
        ++pos_;
      } else if (s_[pos_] == '#') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
      } else {
        break;
      }
    }
  }

  char peek() {
    skip_space();
    if (pos_ >= s_.size()) fail("unexpected end of file (truncated?)");
    return s_[pos_];
  }

  nlohmann::json parse_value() {
    if (++depth_ > kMaxDocumentDepth) fail("nesting too deep");
    if (++values_ > kMaxDocumentNodes) fail("more than " + std::to_string(kMaxDocumentNodes) + " values");
    nlohmann::json value;
    const char c = peek();
    if (c == '{') {
      value = parse_dict();
    } else if (c == '[' || c == '(') {
      value = parse_list(c == '[' ? ']' : ')');
    } else if (c == '\'' || c == '"') {
      value = parse_strings();
    } else if ((c == 'b' || c == 'B') && pos_ + 1 < s_.size() && (s_[pos_ + 1] == '\'' || s_[pos_ + 1] == '"')) {
      ++pos_;  // a bytes literal (mrcal's optimization_inputs): read as a string
      value = parse_strings();
    } else if (std::isalpha(static_cast<unsigned char>(c))) {
      value = parse_word();
    } else {
      value = parse_number();
    }
    --depth_;
    return value;
  }

  nlohmann::json parse_dict() {
    ++pos_;
    nlohmann::json object = nlohmann::json::object();
    while (peek() != '}') {
      if (peek() != '\'' && peek() != '"') fail("expected a quoted key");
      const std::string key = parse_strings();
      if (peek() != ':') fail("expected ':' after key " + quoted_for_message(key));
      ++pos_;
      if (object.contains(key)) fail("duplicate key " + quoted_for_message(key));
      object[key] = parse_value();
      if (peek() == ',') {
        ++pos_;
      } else if (peek() != '}') {
        fail("expected ',' or '}' after the value of " + quoted_for_message(key));
      }
    }
    ++pos_;
    return object;
  }

  nlohmann::json parse_list(char close) {
    ++pos_;
    nlohmann::json array = nlohmann::json::array();
    while (peek() != close) {
      array.push_back(parse_value());
      if (peek() == ',') {
        ++pos_;
      } else if (peek() != close) {
        fail(std::string("expected ',' or '") + close + "' in a list");
      }
    }
    ++pos_;
    return array;
  }

  // One or more adjacent string literals (Python concatenates them).
  std::string parse_strings() {
    std::string out;
    do {
      const char quote = s_[pos_++];
      while (true) {
        if (pos_ >= s_.size() || s_[pos_] == '\n') fail("unterminated string");
        const char c = s_[pos_++];
        if (c == quote) break;
        if (c == '\\') {
          if (pos_ >= s_.size()) fail("unterminated string");
          const char e = s_[pos_++];
          out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
        } else {
          out += c;
        }
      }
      skip_space();
    } while (pos_ < s_.size() && (s_[pos_] == '\'' || s_[pos_] == '"'));
    return out;
  }

  nlohmann::json parse_word() {
    const size_t start = pos_;
    while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) ++pos_;
    const std::string_view word = s_.substr(start, pos_ - start);
    if (word == "True") return true;
    if (word == "False") return false;
    if (word == "None") return nullptr;
    // Python prints non-finite floats as nan / inf; the reader decides what they mean.
    if (word == "nan") return std::numeric_limits<double>::quiet_NaN();
    if (word == "inf") return std::numeric_limits<double>::infinity();
    pos_ = start;
    fail("unexpected word " + quoted_for_message(std::string(word)) +
         " (only numbers, strings, True, False, None are allowed)");
  }

  nlohmann::json parse_number() {
    const size_t start = pos_;
    if (s_[pos_] == '+' || s_[pos_] == '-') ++pos_;
    while (pos_ < s_.size() &&
           (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '.' ||
            ((s_[pos_] == '+' || s_[pos_] == '-') && (s_[pos_ - 1] == 'e' || s_[pos_ - 1] == 'E')))) {
      ++pos_;
    }
    std::string token(s_.substr(start, pos_ - start));
    if (!token.empty() && token[0] == '+') token.erase(0, 1);
    double value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (token.empty() || ec != std::errc() || end != token.data() + token.size()) {
      pos_ = start;
      fail("expected a value, got " + quoted_for_message(token.substr(0, 20)));
    }
    return value;
  }

  std::string_view s_;
  size_t pos_ = 0;
  int depth_ = 0;
  std::size_t values_ = 0;
};

}  // namespace

nlohmann::json parse_python_literal(std::string_view text) { return Parser(text).document(); }

}  // namespace fishcam::detail
