// The protocol's node id of a rig node: the number its `id` is or ends in, parsed once at load time.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_rig.hpp"
#include "voxcap/config/rig_config.hpp"

namespace vc::config {
namespace {

using testing::edit;
using ::testing::HasSubstr;
using testing::TempRig;
using testing::valid_toml;

// Moved here with node_number() from host/aggregator.
TEST(NodeNumber, IsTheNumberTheIdIsOrEndsIn) {
  NodeConfig n;
  n.id = "node12";
  EXPECT_EQ(node_number(n, 0, "r.toml"), 12);
  n.id = "7";
  EXPECT_EQ(node_number(n, 0, "r.toml"), 7);
  n.id = "front";
  EXPECT_THROW(node_number(n, 3, "r.toml"), ConfigError);
}

TEST(NodeNumber, ErrorsNameTheNodesIdKey) {
  NodeConfig n;
  n.id = "front";
  try {
    node_number(n, 3, "r.toml");
    FAIL() << "no number";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "nodes[3].id");
    EXPECT_THAT(e.what(), HasSubstr("'front' must be or end in the node's number (0..65535)"));
  }
  std::string why;
  EXPECT_FALSE(parse_node_number("node70000", &why).has_value());
  EXPECT_EQ(why, "node number 70000 is over 65535");
  EXPECT_FALSE(parse_node_number("node123456", &why).has_value());
  EXPECT_FALSE(parse_node_number("", &why).has_value());
  EXPECT_EQ(parse_node_number("pi-5_a12"), uint16_t{12});
  EXPECT_EQ(parse_node_number("00003"), uint16_t{3});
}

TEST(NodeNumber, IsParsedOnceWhenTheRigIsLoaded) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << valid_toml();
  const RigConfig c = load_rig_config(rig.toml_path());
  ASSERT_EQ(c.nodes.size(), 3u);
  for (size_t k = 0; k < 3; k++) {
    EXPECT_EQ(c.nodes[k].number, uint16_t(k));
    EXPECT_EQ(node_number(c.nodes[k], k, "x"), k);
  }
}

TEST(NodeNumber, ARigWhoseIdsShareANumberIsRejectedAtLoad) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"n2\"");
  try {
    load_rig_config(rig.toml_path());
    FAIL() << "node2 and n2 are both node 2";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "nodes[2].id");
    EXPECT_THAT(e.what(), HasSubstr("node number 2 is used twice"));
  }
}

TEST(NodeNumber, ARigBuiltInCodeMustSetNumbersThatMatchTheIds) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << valid_toml();
  RigConfig c = load_rig_config(rig.toml_path());
  std::string why;
  ASSERT_TRUE(c.valid(&why)) << why;
  c.nodes[1].number = 5;
  EXPECT_FALSE(c.valid(&why));
  EXPECT_EQ(why, "nodes[1].number: 5 does not match its id \"node1\"");
  c.nodes[1].number.reset();
  EXPECT_FALSE(c.valid(&why));
}

TEST(NodeNumber, AnIdWithoutANumberNeedsANumberKey) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"side-b\"");
  try {
    load_rig_config(rig.toml_path());
    FAIL() << "side-b has no number";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "nodes[1].id");
    EXPECT_THAT(e.what(), HasSubstr("or give the node a `number` (0..65535)"));
  }
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"side-b\"\nnumber = 7");
  const RigConfig c = load_rig_config(rig.toml_path());
  EXPECT_EQ(c.nodes[1].number, uint16_t{7});
  EXPECT_EQ(node_number(c.nodes[1], 1, c.source.string()), 7);
  std::string why;
  EXPECT_TRUE(c.valid(&why)) << why;
}

TEST(NodeNumber, AnExplicitNumberMustAgreeWithTheIdsAndBeInRange) {
  TempRig rig;
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"node1\"\nnumber = 4");
  EXPECT_THROW(load_rig_config(rig.toml_path()), ConfigError);  // node1 says 1
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"side\"\nnumber = 70000");
  EXPECT_THROW(load_rig_config(rig.toml_path()), ConfigError);
  std::ofstream(rig.toml_path()) << edit("id = \"node1\"", "id = \"side\"\nnumber = 2");
  EXPECT_THROW(load_rig_config(rig.toml_path()), ConfigError);  // node2 is 2 already
}

}  // namespace
}  // namespace vc::config
