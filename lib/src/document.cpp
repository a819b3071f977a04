#include "document.hpp"

#include <pugixml.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <unordered_set>

#include "fishcam/error.hpp"

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
// indentation): refuse deep nesting before handing the text over.
void check_yaml_nesting(std::string_view content, const std::string& source) {
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

DocNode from_yaml(const YAML::Node& node, int depth, Budget& budget, const std::string& source) {
  budget.spend(source, "YAML");
  if (depth > kMaxDocumentDepth) fail(source, "YAML", "nested too deeply");
  DocNode out;
  out.tag = short_tag(node.Tag());
  if (out.tag == "?") out.tag.clear();  // yaml-cpp's "no tag"
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      out.kind = DocNode::Kind::scalar;
      out.scalar = node.Scalar();
      break;
    case YAML::NodeType::Sequence:
      out.kind = DocNode::Kind::sequence;
      for (const auto& item : node) out.items.push_back(from_yaml(item, depth + 1, budget, source));
      break;
    case YAML::NodeType::Map: {
      out.kind = DocNode::Kind::map;
      std::unordered_set<std::string> seen;
      for (const auto& field : node) {
        if (!field.first.IsScalar()) fail(source, "YAML", "a map key that is not text");
        reject_duplicate_key(seen, field.first.Scalar(), source, "YAML");
        out.keys.push_back(field.first.Scalar());
        out.items.push_back(from_yaml(field.second, depth + 1, budget, source));
      }
      break;
    }
    default:
      out.kind = DocNode::Kind::null;
  }
  return out;
}

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
      if (std::string_view(child.name()) != "_") reject_duplicate_key(seen, child.name(), source, "XML");  // "_": OpenCV's sequence items
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
  check_yaml_nesting(text, source);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(source, "YAML", "line " + std::to_string(e.mark.line + 1) + ": " + quoted_for_message(e.msg));
  }
  Budget budget;
  return from_yaml(root, 0, budget, source);
}

DocNode parse_xml(std::string_view content, const std::string& source) {
  check_size(content, source, "XML");
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
