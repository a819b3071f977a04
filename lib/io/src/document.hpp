// YAML and XML camera files as one small tree, parsed by well-kept libraries
// (yaml-cpp, pugixml) with bounds checked before anything is built: untrusted
// text never reaches cv::FileStorage, whose parser crashes on truncated XML.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace fishcam::detail {

struct DocNode {
  enum class Kind { null, scalar, sequence, map };
  Kind kind = Kind::null;
  std::string tag;                // YAML tag or XML type_id, without "!!" / "tag:yaml.org,2002:" ("opencv-matrix")
  std::string scalar;             // the text of a scalar (XML: the element's text)
  std::vector<DocNode> items;     // a sequence, or a map's values (in file order)
  std::vector<std::string> keys;  // a map's keys, one per item (vector<pair<string, DocNode>>
                                  // would need DocNode complete here)

  // The field `key` of a map (nullptr if absent or not a map).
  const DocNode* find(std::string_view key) const;
};

// Limits on what a camera file may hold (errors, not allocations, past them),
// checked while parsing. The largest real camera files (mrcal's with its
// optimization inputs) hold a few hundred kB; a splined model a few thousand values.
constexpr size_t kMaxDocumentBytes = 16 << 20;
constexpr int kMaxDocumentDepth = 64;
constexpr size_t kMaxDocumentNodes = 1 << 16;

// Throw Error("SOURCE: not a readable YAML file (why)") etc. on any problem.
DocNode parse_yaml(std::string_view content, const std::string& source);
DocNode parse_xml(std::string_view content, const std::string& source);

}  // namespace fishcam::detail
