// A small, bounded XML tag scanner for the importers (Qualisys .qca, and the check of an OpenCV XML file
// before OpenCV's parser sees it). It reports every start, end and empty-element tag with its attributes
// and ignores text. Refused, with one ImportError line naming the line: a DOCTYPE or other `<!` markup
// (no entities to expand), nesting deeper than max_depth, an end tag that does not match, more than
// kMaxXmlAttributes attributes on a tag or kMaxXmlTags tags, an attribute value over kMaxXmlValue bytes,
// a NUL byte, an unknown entity. Only &amp; &lt; &gt; &quot; &apos; are decoded.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vc::calib {

inline constexpr int kMaxXmlAttributes = 64;
inline constexpr std::size_t kMaxXmlValue = 4096;
inline constexpr int kMaxXmlTags = 1 << 20;

struct XmlTag {
  std::string name;
  bool closing = false;       // </name>
  bool self_closing = false;  // <name ... />
  std::vector<std::pair<std::string, std::string>> attrs;
  int line = 0;

  const std::string* attr(std::string_view key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
};

// Calls on_tag for every tag in document order; throws ImportError("PATH: line N: ...").
void scan_xml(std::string_view text, const std::string& path, int max_depth,
              const std::function<void(const XmlTag&)>& on_tag);

}  // namespace vc::calib
