// `voxcap proto dump` prints the fields SPEC.md documents: the field names are read from SPEC.md's
// tables (section "Header" and each "<NAME> (type N)" section with its record tables) and looked up in
// the dump of the vector of that message type; rejections print their code and offset. This tests
// the library function behind the command; cli_test.cpp runs the voxcap binary itself.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "voxcap/proto.h"
#include "voxcap/proto_json.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kProto = PROTO_SOURCE_DIR;

std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Field names per section of SPEC.md: "Header" and the message type names ("HELLO", ...). A field name
// is the backticked word in the "field" column of a table.
std::map<std::string, std::set<std::string>> spec_fields() {
  std::map<std::string, std::set<std::string>> out;
  std::istringstream spec(read_text(kProto / "SPEC.md"));
  std::string line, section;
  int field_col = -1;
  const std::regex heading(R"(^###\s+(Header|([A-Z]+) \(type \d+\)(, ([A-Z]+) \(type \d+\))?)\s*$)");
  while (std::getline(spec, line)) {
    std::smatch m;
    if (line.rfind("## ", 0) == 0) section.clear();
    if (std::regex_match(line, m, heading)) {
      section = m[2].matched ? m[2].str() : m[1].str();
      if (m[4].matched) out[m[4].str()];  // "START (type 4), STOP (type 5)": no fields
      out[section];
      field_col = -1;
      continue;
    }
    if (section.empty() || line.empty() || line[0] != '|') continue;
    std::vector<std::string> cells;
    std::stringstream row(line.substr(1));
    for (std::string cell; std::getline(row, cell, '|');) cells.push_back(cell);
    for (auto& c : cells) c = std::regex_replace(c, std::regex(R"(^\s+|\s+$)"), "");
    if (std::find(cells.begin(), cells.end(), "field") != cells.end()) {
      field_col = static_cast<int>(std::find(cells.begin(), cells.end(), "field") - cells.begin());
      continue;
    }
    if (field_col < 0 || field_col >= static_cast<int>(cells.size())) continue;
    std::smatch f;
    const std::string cell = cells[field_col];
    if (std::regex_match(cell, f, std::regex(R"(`([a-zA-Z_]+)`)"))) out[section].insert(f[1]);
  }
  return out;
}

TEST(SpecFields, AreParsedFromTheSpec) {
  const auto fields = spec_fields();
  EXPECT_TRUE(fields.at("Header").count("header_crc"));
  EXPECT_TRUE(fields.at("HULL").count("occupied_count"));
  EXPECT_TRUE(fields.at("CONFIG").count("R_cam_from_world"));  // from the calibration record table
  EXPECT_TRUE(fields.at("STATS").count("counter_id"));
  EXPECT_TRUE(fields.count("STOP"));
  for (uint16_t t = VC_MSG_HELLO; t <= VC_MSG_SILHOUETTE; t++)
    EXPECT_TRUE(fields.count(vc_msg_type_name(t))) << t;
  EXPECT_TRUE(fields.at("SILHOUETTE").count("foreground_count"));
  EXPECT_TRUE(fields.at("CONFIG").count("carve_rule"));
}

// The text dump of the one-message vector of each type names every documented field.
TEST(Dump, TextNamesEveryDocumentedField) {
  const auto fields = spec_fields();
  const std::map<std::string, std::string> vector_of = {
      {"HELLO", "hello"},         {"CONFIG", "config"}, {"BACKGROUND", "background"}, {"START", "start"},
      {"STOP", "stop"},           {"HULL", "hull"},     {"FEATURES", "features"},     {"STATS", "stats"},
      {"HEARTBEAT", "heartbeat"}, {"ERROR", "error"},   {"SILHOUETTE", "silhouette"}};
  for (const auto& [type, name] : vector_of) {
    SCOPED_TRACE(type);
    std::ifstream in(kProto / "vectors" / (name + ".bin"), std::ios::binary);
    std::ostringstream out;
    vc::proto::DumpOptions opt;
    const auto r = vc::proto::dump(in, out, opt);
    EXPECT_TRUE(r.ok());
    EXPECT_EQ(r.messages, 1u);
    const std::string text = out.str();
    EXPECT_NE(text.find("@0 " + type + "\n"), std::string::npos) << text;
    std::set<std::string> wanted = fields.at("Header");
    wanted.insert(fields.at(type).begin(), fields.at(type).end());
    for (const std::string& f : wanted) {
      const std::regex word("(^|[ \\[])" + f + "(=|:| |\\[)", std::regex::multiline);
      EXPECT_TRUE(std::regex_search(text, word)) << "field `" << f << "` missing from:\n" << text;
    }
  }
}

TEST(Dump, JsonLinesHaveTheDocumentedFieldsAsKeys) {
  const auto fields = spec_fields();
  std::ifstream in(kProto / "vectors" / "session.bin", std::ios::binary);
  std::ostringstream out;
  vc::proto::DumpOptions opt;
  opt.json = true;
  const auto r = vc::proto::dump(in, out, opt);
  EXPECT_TRUE(r.ok());
  std::istringstream lines(out.str());
  size_t n = 0;
  for (std::string line; std::getline(lines, line); n++) {
    const auto j = vc::proto::Json::parse(line);
    const auto& m = j.at("message");
    for (const std::string& f : fields.at("Header")) EXPECT_TRUE(m["header"].contains(f)) << f;
    const std::string type = m["type"];
    const std::string flat = m["body"].dump();
    for (const std::string& f : fields.at(type))
      EXPECT_NE(flat.find("\"" + f + "\""), std::string::npos) << type << "." << f;
  }
  EXPECT_EQ(n, r.messages);
  // The session vector: 6 setup messages, 2 frames x 3, the first frame's 2 SILHOUETTEs, STATS, STOP.
  EXPECT_EQ(n, 16u);
}

TEST(Dump, ReportsErrorsWithCodeAndOffset) {
  std::ifstream in(kProto / "vectors" / "bad_magic.bin", std::ios::binary);
  std::ostringstream out;
  const auto r = vc::proto::dump(in, out, vc::proto::DumpOptions{});
  EXPECT_EQ(r.fatal, VC_PROTO_EMAGIC);
  EXPECT_EQ(r.fatal_offset, 52u);
  EXPECT_NE(out.str().find("@52 FATAL VC_PROTO_EMAGIC"), std::string::npos) << out.str();
  std::ifstream in2(kProto / "vectors" / "truncated_payload.bin", std::ios::binary);
  std::ostringstream out2;
  const auto r2 = vc::proto::dump(in2, out2, vc::proto::DumpOptions{});
  EXPECT_EQ(r2.fatal, 0);
  EXPECT_EQ(r2.rejected, 1u);
  EXPECT_EQ(r2.messages, 1u);
  EXPECT_NE(out2.str().find("@0 REJECTED VC_PROTO_ETRUNCATED"), std::string::npos) << out2.str();
  EXPECT_NE(out2.str().find("@60 HEARTBEAT"), std::string::npos) << out2.str();
  vc::proto::DumpOptions bad;
  bad.max_payload = VC_PROTO_MAX_PAYLOAD + 1;
  std::string why;
  EXPECT_FALSE(bad.valid(&why));
  EXPECT_NE(why.find("max_payload"), std::string::npos);
}

}  // namespace
