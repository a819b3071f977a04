#include "document.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>
#include <pugixml.hpp>

#include <algorithm>
#include <sstream>
#include <unordered_set>

#include "fishcam/core/error.hpp"

namespace fishcam::detail {
namespace {

[[noreturn]] void fail(const std::string& source, const char* kind, const std::string& why) {
  throw Error(source + ": not a readable " + kind + " file (" + why + ")");
}

void check_size(std::string_view content, const std::string& source, const char* kind) {
  if (content.size() > kMaxDocumentBytes) {
    fail(source, kind, "larger than " + std::to_string(kMaxDocumentBytes >> 20) + " MiB");
  }
}

// yaml-cpp's parser recurses per nesting level (flow brackets and block
// indentation), and its scanner queues every token of a flow mapping before the
// first event (a 16 MiB "{a: [1, 1, ...]}" took 2.4 GB): refuse deep nesting and
// more lines or flow separators than the node budget before handing the text over.
void check_yaml_shape(std::string_view content, const std::string& source) {
  const auto lines = std::count(content.begin(), content.end(), '\n');
  const auto separators = std::count(content.begin(), content.end(), ',');
  if (size_t(std::max(lines, separators)) > kMaxDocumentNodes) {
    fail(source, "YAML",
         "more than " + std::to_string(kMaxDocumentNodes) + (lines > separators ? " lines" : " commas"));
  }
  int depth = 0;
  size_t line_start = 0;
  for (size_t i = 0; i < content.size(); ++i) {
    const char c = content[i];
    if (c == '[' || c == '{') {
      if (++depth > kMaxDocumentDepth) fail(source, "YAML", "nested deeper than " + std::to_string(kMaxDocumentDepth));
    } else if (c == ']' || c == '}') {
      depth = std::max(0, depth - 1);
    } else if (c == '\n') {
      line_start = i + 1;
    } else if (c != ' ' && c != '-' && i - line_start > size_t(4 * kMaxDocumentDepth)) {
      // Block nesting shows as indentation (and "- - -" sequences).
      const std::string_view prefix = content.substr(line_start, i - line_start);
      if (prefix.find_first_not_of(" -") == std::string_view::npos) {
        fail(source, "YAML", "indented deeper than " + std::to_string(4 * kMaxDocumentDepth) + " columns");
      }
    }
  }
}

std::string short_tag(std::string tag) {
  for (const char* prefix : {"tag:yaml.org,2002:", "!!", "!"}) {
    if (tag.rfind(prefix, 0) == 0) return tag.substr(std::string(prefix).size());
  }
  return tag;
}

struct Budget {
  size_t nodes = 0;
  void spend(const std::string& source, const char* kind) {
    if (++nodes > kMaxDocumentNodes) fail(source, kind, "more than " + std::to_string(kMaxDocumentNodes) + " nodes");
  }
};

// Which of two equal keys is meant differs between parsers (yaml-cpp keeps the
// first, PyYAML the last): refused, naming the key.
void reject_duplicate_key(std::unordered_set<std::string>& seen, const std::string& key, const std::string& source,
                          const char* kind) {
  if (!seen.insert(key).second) fail(source, kind, "the key " + quoted_for_message(key) + " appears twice in one map");
}

// Builds the tree from yaml-cpp's parser events, spending the node budget as
// each node arrives: a hostile file fails after at most kMaxDocumentNodes nodes
// (yaml-cpp's own tree of a 16 MiB list took 4 GB before a check on it could run).
class YamlTreeBuilder : public YAML::EventHandler {
 public:
  explicit YamlTreeBuilder(const std::string& source) : source_(source) {}
  DocNode take_root() { return std::move(root_); }

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override { add(DocNode{}); }
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {
    fail(source_, "YAML", "aliases (*name) are not read in camera files");
  }
  void OnScalar(const YAML::Mark&, const std::string& tag, YAML::anchor_t, const std::string& value) override {
    DocNode node;
    node.kind = DocNode::Kind::scalar;
    node.tag = tag_of(tag);
    node.scalar = value;
    add(std::move(node));
  }
  void OnSequenceStart(const YAML::Mark&, const std::string& tag, YAML::anchor_t, YAML::EmitterStyle::value) override {
    open(DocNode::Kind::sequence, tag);
  }
  void OnSequenceEnd() override { close(); }
  void OnMapStart(const YAML::Mark&, const std::string& tag, YAML::anchor_t, YAML::EmitterStyle::value) override {
    open(DocNode::Kind::map, tag);
  }
  void OnMapEnd() override { close(); }

 private:
  struct Open {
    DocNode node;
    bool expect_key = true;  // maps: keys and values alternate
    std::string key;
    std::unordered_set<std::string> seen;
  };

  static std::string tag_of(const std::string& tag) {
    std::string t = short_tag(tag);
    return t == "?" ? std::string() : t;  // yaml-cpp's "no tag"
  }
  void open(DocNode::Kind kind, const std::string& tag) {
    budget_.spend(source_, "YAML");
    if (int(stack_.size()) >= kMaxDocumentDepth) fail(source_, "YAML", "nested too deeply");
    stack_.emplace_back();
    stack_.back().node.kind = kind;
    stack_.back().node.tag = tag_of(tag);
  }
  void close() {
    DocNode done = std::move(stack_.back().node);
    stack_.pop_back();
    place(std::move(done));
  }
  void add(DocNode node) {
    budget_.spend(source_, "YAML");
    place(std::move(node));
  }
  void place(DocNode node) {
    if (stack_.empty()) {
      root_ = std::move(node);
      return;
    }
    Open& parent = stack_.back();
    if (parent.node.kind == DocNode::Kind::sequence) {
      parent.node.items.push_back(std::move(node));
    } else if (parent.expect_key) {
      if (node.kind != DocNode::Kind::scalar) fail(source_, "YAML", "a map key that is not text");
      reject_duplicate_key(parent.seen, node.scalar, source_, "YAML");
      parent.key = std::move(node.scalar);
      parent.expect_key = false;
    } else {
      parent.node.keys.push_back(std::move(parent.key));
      parent.node.items.push_back(std::move(node));
      parent.expect_key = true;
    }
  }

  const std::string& source_;
  Budget budget_;
  std::vector<Open> stack_;
  DocNode root_;
};

DocNode from_xml(const pugi::xml_node& node, int depth, Budget& budget, const std::string& source) {
  budget.spend(source, "XML");
  if (depth > kMaxDocumentDepth) fail(source, "XML", "nested too deeply");
  DocNode out;
  out.tag = node.attribute("type_id").value();
  bool has_elements = false;
  std::unordered_set<std::string> seen;
  for (const pugi::xml_node& child : node.children()) {
    if (child.type() == pugi::node_element) {
      has_elements = true;
      if (std::string_view(child.name()) != "_")
        reject_duplicate_key(seen, child.name(), source, "XML");  // "_": OpenCV's sequence items
      out.keys.push_back(child.name());
      out.items.push_back(from_xml(child, depth + 1, budget, source));
    }
  }
  if (has_elements) {
    out.kind = DocNode::Kind::map;
    return out;
  }
  out.kind = DocNode::Kind::scalar;
  out.scalar = node.text().get();
  return out;
}

}  // namespace

const DocNode* DocNode::find(std::string_view key) const {
  if (kind != Kind::map) return nullptr;
  for (size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] == key) return &items[i];
  }
  return nullptr;
}

DocNode parse_yaml(std::string_view content, const std::string& source) {
  check_size(content, source, "YAML");
  std::string text(content);
  // OpenCV writes a non-standard "%YAML:1.0" directive: blank it (line numbers stay).
  if (text.rfind("%YAML:", 0) == 0) {
    const size_t end = text.find('\n');
    std::fill(text.begin(), end == std::string::npos ? text.end() : text.begin() + long(end), ' ');
  }
  check_yaml_shape(text, source);
  std::istringstream stream(text);
  YamlTreeBuilder builder(source);
  try {
    YAML::Parser parser(stream);
    parser.HandleNextDocument(builder);  // the first document, as YAML::Load reads
  } catch (const YAML::Exception& e) {
    fail(source, "YAML", "line " + std::to_string(e.mark.line + 1) + ": " + quoted_for_message(e.msg));
  }
  return builder.take_root();
}

DocNode parse_xml(std::string_view content, const std::string& source) {
  check_size(content, source, "XML");
  // pugixml builds its whole tree first: bound the elements (each opens with '<') before.
  if (size_t(std::count(content.begin(), content.end(), '<')) > 2 * kMaxDocumentNodes) {
    fail(source, "XML", "more than " + std::to_string(kMaxDocumentNodes) + " elements");
  }
  pugi::xml_document document;
  const pugi::xml_parse_result result = document.load_buffer(content.data(), content.size());
  if (!result) {
    fail(source, "XML", std::string(result.description()) + " at byte " + std::to_string(result.offset));
  }
  const pugi::xml_node root = document.document_element();
  if (!root) fail(source, "XML", "no root element");
  Budget budget;
  return from_xml(root, 0, budget, source);
}

}  // namespace fishcam::detail
