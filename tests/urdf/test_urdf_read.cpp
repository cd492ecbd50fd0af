// The URDF reader and header writer: what a file means (conventions), and that every bad file
// ends in one UrdfError naming the file, the line, the joint or link and the problem.
#include <gtest/gtest.h>

#include <string>

#include <eomgen/urdf.hpp>

namespace {

using eom::urdf::JointType;
using eom::urdf::UrdfError;

const char* const kInertia = R"(<inertia ixx="0.1" iyy="0.1" izz="0.02" ixy="0" ixz="0" iyz="0"/>)";

// A robot base -> a (joint j1) -> b (joint j2), with `joint2` and `link_b` spliced in.
std::string robot(const std::string& joint2 = "", const std::string& link_b = "") {
  return std::string(R"(<?xml version="1.0"?>
<robot name="r">
  <link name="base"/>
  <link name="a"><inertial><mass value="1"/>)") + kInertia + R"(</inertial></link>
  )" + (link_b.empty() ? std::string(R"(<link name="b"><inertial><mass value="1"/>)") + kInertia + "</inertial></link>" : link_b) + R"(
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/></joint>
  )" + (joint2.empty() ? R"(<joint name="j2" type="prismatic"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 1" rpy="0.1 0.2 0.3"/><axis xyz="0 3 4"/><dynamics damping="0.5"/></joint>)" : joint2) + R"(
</robot>)";
}

// The message of the UrdfError that parsing `text` throws ("" when it throws none).
std::string error_of(const std::string& text) {
  try {
    eom::urdf::Robot r = eom::urdf::parse(text, "robot.urdf");
    (void)eom::urdf::model_header(r);
  } catch (const UrdfError& e) {
    return e.what();
  }
  return "";
}

TEST(UrdfRead, ReadsJointsLinksAndInertials) {
  const auto r = eom::urdf::parse(robot(), "robot.urdf");
  EXPECT_EQ(r.name, "r");
  EXPECT_EQ(r.root, "base");
  ASSERT_EQ(r.joints.size(), 2u);
  const auto& j2 = r.joints[1];
  EXPECT_EQ(j2.type, JointType::prismatic);
  EXPECT_EQ(j2.parent, "a");
  EXPECT_EQ(j2.child, "b");
  EXPECT_EQ(j2.origin.rpy[2], 0.3);
  EXPECT_EQ(j2.axis[1], 3.0);  // kept as written; normalized where it is used
  EXPECT_EQ(j2.damping, 0.5);
  EXPECT_EQ(r.joints[0].damping, 0.0);  // absent: 0
  ASSERT_EQ(r.links.size(), 3u);
  EXPECT_FALSE(r.links[0].has_inertial);  // massless
  EXPECT_TRUE(r.links[1].has_inertial);
  EXPECT_EQ(r.links[1].inertial.inertia[2], 0.02);
}

TEST(UrdfRead, HeaderNamesCoordinatesInputsAndParameters) {
  const std::string h = eom::urdf::model_header(eom::urdf::parse(robot(), "dir/robot.urdf"));
  EXPECT_NE(h.find(R"(coordinates{"j1", "j2"})"), std::string::npos) << h;
  EXPECT_NE(h.find(R"(inputs{"u_j1", "u_j2"})"), std::string::npos) << h;
  EXPECT_NE(h.find(R"("g", "a_mass", "a_com_x")"), std::string::npos) << h;
  EXPECT_NE(h.find(R"("j2_damping")"), std::string::npos) << h;
  EXPECT_NE(h.find("from robot.urdf"), std::string::npos) << "no directories in the header\n" << h;
  EXPECT_NE(h.find(".prismatic = true, .axis = {0.0, 3.0, 4.0}"), std::string::npos) << h;
  EXPECT_NE(h.find(".parent = 0, .origin = origin<S>({0.0, 0.0, 1.0}, {0.1, 0.2, 0.3}), .coordinate = 1"),
            std::string::npos) << h;
}

TEST(UrdfRead, NamesBecomeIdentifiers) {
  EXPECT_EQ(eom::urdf::identifier("panda-joint 1", "joint_"), "panda_joint_1");
  EXPECT_EQ(eom::urdf::identifier("1st", "joint_"), "joint_1st");
  EXPECT_EQ(eom::urdf::identifier("", "link_"), "link_");
}

struct BadCase {
  const char* label;
  std::string text;
  const char* expect;  // a part of the message
};

TEST(UrdfRead, EveryBadFileGetsAMessageNamingWhatIsWrong) {
  const BadCase cases[] = {
      {"malformed XML", "<robot name=\"r\"><link name=\"a\"></robot>", "robot.urdf:1: malformed XML"},
      {"not a robot", "<?xml version=\"1.0\"?><model/>", "the top element must be <robot>"},
      {"unknown link",
       robot(R"(<joint name="j2" type="fixed"><parent link="a"/><child link="nowhere"/></joint>)"),
       "joint 'j2': unknown link 'nowhere'"},
      {"zero axis",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/></joint>)"),
       "joint 'j2': zero joint axis"},
      {"negative mass", robot("", R"(<link name="b"><inertial><mass value="-1"/>)" + std::string(kInertia) + "</inertial></link>"),
       "link 'b': negative mass"},
      {"not positive definite",
       robot("", R"(<link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="2" ixz="0" iyz="0"/></inertial></link>)"),
       "link 'b': inertia tensor is not positive definite"},
      {"triangle inequality",
       robot("", R"(<link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="3" ixy="0" ixz="0" iyz="0"/></inertial></link>)"),
       "link 'b': inertia tensor violates the triangle inequality"},
      {"kinematic loop",
       robot(R"(<joint name="j2" type="fixed"><parent link="a"/><child link="b"/></joint>
                <joint name="j3" type="fixed"><parent link="b"/><child link="a"/></joint>)"),
       "joint 'j3': link 'a' is already the child of joint 'j1'"},
      {"two roots",
       robot(R"(<joint name="j2" type="fixed"><parent link="b"/><child link="b2"/></joint><link name="b2"/>)"),
       "more than one root link ('base', 'b')"},
      {"floating joint below the root",
       robot(R"(<joint name="j2" type="floating"><parent link="a"/><child link="b"/></joint>)"),
       "joint 'j2': a floating joint must hang from the root link 'base'"},
      {"planar joint",
       robot(R"(<joint name="j2" type="planar"><parent link="a"/><child link="b"/></joint>)"),
       "joint 'j2': planar joints are not supported yet"},
      {"mimic joint",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j1"/></joint>)"),
       "joint 'j2': <mimic> joints are not supported yet"},
      {"unknown type",
       robot(R"(<joint name="j2" type="ball"><parent link="a"/><child link="b"/></joint>)"),
       "joint 'j2': unknown joint type 'ball'"},
      {"bad number",
       robot(R"(<joint name="j2" type="fixed"><parent link="a"/><child link="b"/><origin xyz="0 zero 1"/></joint>)"),
       "joint 'j2': origin xyz=\"0 zero 1\": not a number"},
      {"too few numbers",
       robot(R"(<joint name="j2" type="fixed"><parent link="a"/><child link="b"/><origin rpy="0 1"/></joint>)"),
       "expected 3 numbers"},
      {"infinite number",
       robot(R"(<joint name="j2" type="fixed"><parent link="a"/><child link="b"/><origin xyz="0 0 1e999"/></joint>)"),
       "joint 'j2': origin xyz=\"0 0 1e999\": out of the range of double"},
      {"missing mass", robot("", R"(<link name="b"><inertial>)" + std::string(kInertia) + "</inertial></link>"),
       "link 'b': <inertial> has no <mass>"},
      {"duplicate joint",
       robot(R"(<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>)"),
       "joint 'j1' is defined twice"},
      {"no parent", robot(R"(<joint name="j2" type="fixed"><child link="b"/></joint>)"),
       "joint 'j2': no <parent link=...>"},
      {"negative damping",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><dynamics damping="-1"/></joint>)"),
       "joint 'j2': negative damping"},
  };
  for (const auto& c : cases) {
    const std::string message = error_of(c.text);
    EXPECT_NE(message.find(c.expect), std::string::npos)
        << c.label << ": expected \"" << c.expect << "\" in \"" << message << "\"";
    EXPECT_EQ(message.rfind("robot.urdf:", 0), 0u) << c.label << ": the file first: " << message;
  }
}

// A free robot: world -> (floating) base -> a (j1) -> b (j2); `extra` spliced in.
std::string free_robot(const std::string& floating_origin = "", const std::string& extra = "",
                       const std::string& world = R"(<link name="world"/>)") {
  return world + R"(<link name="base"><inertial><mass value="3"/>)" + kInertia +
         R"(</inertial></link>
    <joint name="free" type="floating"><parent link="world"/><child link="base"/>)" +
         floating_origin + "</joint>" + extra;
}
std::string wrapped(const std::string& body) {
  return robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/></joint>)")
      .replace(robot().find("<link name=\"base\"/>"), std::string("<link name=\"base\"/>").size(),
               body);
}

TEST(UrdfRead, AFloatingJointFromTheWorldFreesItsChild) {
  const auto r = eom::urdf::parse(wrapped(free_robot()), "robot.urdf");
  EXPECT_TRUE(r.floating);
  EXPECT_EQ(r.root, "base");
  for (const auto& l : r.links) EXPECT_NE(l.name, "world");
  for (const auto& j : r.joints) EXPECT_NE(j.name, "free");
  const std::string h = eom::urdf::model_header(r);
  EXPECT_NE(h.find(R"(coordinates{"base_x", "base_y", "base_z", "base_qw", "base_qx",)"), std::string::npos) << h;
  EXPECT_NE(h.find(R"("base_qy", "base_qz", "j1", "j2"};)"), std::string::npos) << h;
  EXPECT_NE(h.find("static constexpr bool floating_base = true;"), std::string::npos) << h;
  EXPECT_NE(h.find("l[0] = {.parent = -1, .coordinate = 0, .free = true"), std::string::npos) << h;
  EXPECT_NE(h.find(R"(inputs{"u_j1", "u_j2"})"), std::string::npos) << h;
  EXPECT_NE(h.find("Q[6] = u[0];"), std::string::npos) << h;
  // FLOATING_BASE frees a welded root the same way
  const auto welded = eom::urdf::parse(robot(), "robot.urdf", true);
  EXPECT_TRUE(welded.floating);
  EXPECT_EQ(welded.root, "base");
}

TEST(UrdfRead, MisplacedFloatingJointsAreRefused) {
  const BadCase cases[] = {
      {"with an origin", wrapped(free_robot(R"(<origin xyz="0 0 1"/>)")),
       "joint 'free': a floating joint's <origin> must be the identity"},
      {"a second one",
       wrapped(free_robot("", R"(<link name="c"/><joint name="free2" type="floating"><parent link="b"/><child link="c"/></joint>)")),
       "a second floating joint"},
      {"from a massive world",
       wrapped(free_robot("", "", R"(<link name="world"><inertial><mass value="1"/>)" + std::string(kInertia) + "</inertial></link>")),
       "link 'world': the parent of floating joint 'free' has <inertial>"},
      {"something else on the world",
       wrapped(free_robot("", R"(<link name="post"/><joint name="weld" type="fixed"><parent link="world"/><child link="post"/></joint>)")),
       "joint 'weld': attached to 'world'"},
  };
  for (const auto& c : cases) {
    const std::string message = error_of(c.text);
    EXPECT_NE(message.find(c.expect), std::string::npos)
        << c.label << ": expected \"" << c.expect << "\" in \"" << message << "\"";
    EXPECT_EQ(message.rfind("robot.urdf:", 0), 0u) << c.label << ": the file first: " << message;
  }
  try {  // FLOATING_BASE on a file that has a floating joint
    (void)eom::urdf::parse(wrapped(free_robot()), "robot.urdf", true);
    FAIL() << "no error";
  } catch (const UrdfError& e) {
    EXPECT_NE(std::string(e.what()).find("has a floating joint already; leave out FLOATING_BASE"),
              std::string::npos) << e.what();
  }
}

TEST(UrdfRead, ALoopBelowTheRootIsFound) {
  // base -> a; b <-> c form a loop that hangs from nothing.
  const std::string text = R"(<robot name="r"><link name="base"/><link name="a"/><link name="b"/><link name="c"/>
    <joint name="j1" type="revolute"><parent link="base"/><child link="a"/></joint>
    <joint name="j2" type="revolute"><parent link="b"/><child link="c"/></joint>
    <joint name="j3" type="revolute"><parent link="c"/><child link="b"/></joint></robot>)";
  EXPECT_NE(error_of(text).find("is not connected to the root link 'base' (a kinematic loop)"),
            std::string::npos) << error_of(text);
}

TEST(UrdfRead, ARobotWithoutMovingMassIsRefused) {
  const std::string text = R"(<robot name="r"><link name="base"/><link name="a"/>
    <joint name="j1" type="revolute"><parent link="base"/><child link="a"/></joint></robot>)";
  EXPECT_NE(error_of(text).find("no link that moves has mass"), std::string::npos) << error_of(text);
}

TEST(UrdfRead, AMissingFileIsNamed) {
  try {
    (void)eom::urdf::read("/no/such/robot.urdf");
    FAIL() << "no error";
  } catch (const UrdfError& e) {
    EXPECT_STREQ(e.what(), "/no/such/robot.urdf: cannot open the file");
  }
}

}  // namespace
