#include "xml_scan.hpp"

#include <cctype>

#include "voxcap/calib/import.hpp"

namespace vc::calib {
namespace {

bool name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
}

}  // namespace

void scan_xml(std::string_view text, const std::string& path, int max_depth,
              const std::function<void(const XmlTag&)>& on_tag) {
  std::size_t i = 0;
  int line = 1, tags = 0;
  std::vector<std::string> open;
  const auto fail = [&](const std::string& what) {
    throw ImportError(path + ": line " + std::to_string(line) + ": " + what);
  };
  const auto advance_to = [&](std::string_view end) {  // past the next `end`, counting lines
    const std::size_t e = text.find(end, i);
    if (e == std::string_view::npos) fail("unterminated markup (no '" + std::string(end) + "')");
    for (std::size_t k = i; k < e; ++k) line += text[k] == '\n';
    i = e + end.size();
  };
  const auto skip_space = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) line += text[i++] == '\n';
  };
  const auto read_name = [&] {
    const std::size_t b = i;
    while (i < text.size() && name_char(text[i])) ++i;
    if (i == b || i - b > 256) fail("expected a name of 1 to 256 characters");
    return std::string(text.substr(b, i - b));
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\0') fail("a NUL byte");
    if (c != '<') {
      line += c == '\n';
      ++i;
      continue;
    }
    ++i;
    if (text.substr(i, 3) == "!--") {
      advance_to("-->");
      continue;
    }
    if (i < text.size() && text[i] == '?') {
      advance_to("?>");
      continue;
    }
    if (i < text.size() && text[i] == '!') fail("DOCTYPE, CDATA and other <! markup are not accepted");
    if (++tags > kMaxXmlTags) fail("more than " + std::to_string(kMaxXmlTags) + " tags");
    XmlTag tag;
    tag.line = line;
    if (i < text.size() && text[i] == '/') {
      ++i;
      tag.closing = true;
      tag.name = read_name();
      skip_space();
      if (i >= text.size() || text[i] != '>') fail("expected '>' after </" + tag.name);
      ++i;
      if (open.empty() || open.back() != tag.name) fail("</" + tag.name + "> closes nothing open");
      open.pop_back();
      on_tag(tag);
      continue;
    }
    tag.name = read_name();
    for (;;) {
      skip_space();
      if (i >= text.size()) fail("unterminated <" + tag.name + ">");
      if (text[i] == '>') {
        ++i;
        break;
      }
      if (text[i] == '/') {
        if (i + 1 >= text.size() || text[i + 1] != '>') fail("expected '/>' in <" + tag.name + ">");
        i += 2;
        tag.self_closing = true;
        break;
      }
      if (static_cast<int>(tag.attrs.size()) >= kMaxXmlAttributes)
        fail("more than " + std::to_string(kMaxXmlAttributes) + " attributes in <" + tag.name + ">");
      std::string key = read_name();
      skip_space();
      if (i >= text.size() || text[i] != '=') fail("expected '=' after " + key);
      ++i;
      skip_space();
      if (i >= text.size() || (text[i] != '"' && text[i] != '\'')) fail("expected a quoted value for " + key);
      const char q = text[i++];
      std::string value;
      while (i < text.size() && text[i] != q) {
        const char v = text[i];
        if (v == '<' || v == '\0') fail("'<' or NUL in the value of " + key);
        if (value.size() >= kMaxXmlValue)
          fail("the value of " + key + " is longer than " + std::to_string(kMaxXmlValue) + " bytes");
        if (v == '&') {
          static constexpr std::pair<std::string_view, char> kEnt[] = {
              {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
          bool known = false;
          for (const auto& [ent, ch] : kEnt)
            if (text.substr(i, ent.size()) == ent) {
              value.push_back(ch);
              i += ent.size();
              known = true;
              break;
            }
          if (!known) fail("an unknown entity in the value of " + key);
          continue;
        }
        line += v == '\n';
        value.push_back(v);
        ++i;
      }
      if (i >= text.size()) fail("unterminated value of " + key);
      ++i;
      tag.attrs.emplace_back(std::move(key), std::move(value));
    }
    if (!tag.self_closing) {
      if (static_cast<int>(open.size()) >= max_depth)
        fail("nested more than " + std::to_string(max_depth) + " levels deep");
      open.push_back(tag.name);
    }
    on_tag(tag);
  }
  if (!open.empty()) fail("<" + open.back() + "> is not closed");
}

}  // namespace vc::calib
