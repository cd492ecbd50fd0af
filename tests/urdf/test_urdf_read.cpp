// The URDF reader and header writer: what a file means (conventions), and that every bad file
// ends in one UrdfError naming the file, the line, the joint or link and the problem.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

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
       "link 'b': inertia tensor violates the triangle inequality, largest moment > sum of the other "
       "two (principal moments 1, 1, 3); to take the file as published, accept it with "
       "add_eom_model(... INERTIA_POLICY warn)"},
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
      {"mimic of an unknown joint",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="nope"/></joint>)"),
       "joint 'j2': <mimic joint=\"nope\">: no joint of that name"},
      {"mimic of itself",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j2"/></joint>)"),
       "joint 'j2': <mimic joint> names the joint itself"},
      {"mimic of a fixed joint",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j3"/></joint>
                <link name="c"/><joint name="j3" type="fixed"><parent link="b"/><child link="c"/></joint>)"),
       "joint 'j2': <mimic joint=\"j3\">: that joint is fixed, not a one-degree-of-freedom joint"},
      {"a loop of mimics",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j3"/></joint>
                <link name="c"/><joint name="j3" type="revolute"><parent link="b"/><child link="c"/><mimic joint="j2"/></joint>)"),
       "joint 'j2': mimic joints form a loop ('j2' -> 'j3' -> 'j2')"},
      {"two mimics",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic joint="j1"/><mimic joint="j1"/></joint>)"),
       "joint 'j2': more than one <mimic>"},
      {"mimic without a leader",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><mimic multiplier="2"/></joint>)"),
       "joint 'j2': <mimic> has no joint attribute"},
      {"negative friction",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><dynamics friction="-1"/></joint>)"),
       "joint 'j2': negative friction"},
      {"crossed limits",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><limit lower="1" upper="-1" effort="1" velocity="1"/></joint>)"),
       "joint 'j2': <limit> lower 1.000000 > upper -1.000000; swap them"},
      {"negative effort limit",
       robot(R"(<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><limit effort="-1" velocity="1"/></joint>)"),
       "joint 'j2': <limit> effort and velocity must be >= 0"},
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

namespace {

// base -> a (j1, revolute) -> b (j2) -> c (j3): j2 and j3 as given.
std::string chain3(const std::string& j2, const std::string& j3) {
  const std::string mass = std::string(R"(<inertial><mass value="1"/>)") + kInertia + "</inertial>";
  return R"(<robot name="r"><link name="base"/><link name="a">)" + mass + R"(</link><link name="b">)" +
         mass + R"(</link><link name="c">)" + mass + R"(</link>
    <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
      <limit lower="-1" upper="2" effort="30" velocity="4"/><dynamics damping="0.25" friction="0.5"/></joint>
    <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 1"/>
      <axis xyz="0 1 0"/>)" + j2 + R"(</joint>
    <joint name="j3" type="continuous"><parent link="b"/><child link="c"/><origin xyz="0 0 1"/>
      <axis xyz="1 0 0"/>)" + j3 + R"(</joint></robot>)";
}

}  // namespace

TEST(UrdfMimic, AMimicJointMovesWithItsLeadersCoordinate) {
  const auto r = eom::urdf::parse(chain3(R"(<mimic joint="j1" multiplier="2" offset="0.5"/>)", ""), "m.urdf");
  ASSERT_TRUE(r.joints[1].mimic);
  EXPECT_EQ(r.joints[1].mimic->leader, "j1");
  const std::string h = eom::urdf::model_header(r);
  EXPECT_NE(h.find(R"(std::array coordinates{"j1", "j3"})"), std::string::npos) << h;
  EXPECT_NE(h.find(".multiplier = 2.0, .offset = 0.5"), std::string::npos) << h;
  EXPECT_NE(h.find("(mimics 'j1')"), std::string::npos) << h;
}

TEST(UrdfMimic, AChainOfMimicsIsComposed) {
  // j3 = 3 j2 + 1, j2 = 2 j1 + 0.5: j3 = 6 j1 + 2.5
  const auto r = eom::urdf::parse(chain3(R"(<mimic joint="j1" multiplier="2" offset="0.5"/>)",
                                         R"(<mimic joint="j2" multiplier="3" offset="1"/>)"),
                                  "m.urdf");
  ASSERT_TRUE(r.joints[2].mimic);
  EXPECT_EQ(r.joints[2].mimic->leader, "j1");
  EXPECT_EQ(r.joints[2].mimic->written_leader, "j2");
  EXPECT_EQ(r.joints[2].mimic->multiplier, 6.0);
  EXPECT_EQ(r.joints[2].mimic->offset, 2.5);
  const std::string h = eom::urdf::model_header(r);
  EXPECT_NE(h.find(R"(std::array coordinates{"j1"})"), std::string::npos) << h;
}

TEST(UrdfMimic, AMimicOnAFixedJointIsIgnoredWithAWarning) {
  std::string text = chain3("", "");
  const std::string from = R"(<joint name="j3" type="continuous">)";
  text.replace(text.find(from), from.size(), R"(<joint name="j3" type="fixed"><mimic joint="j1"/>)");
  const auto r = eom::urdf::parse(text, "m.urdf");
  EXPECT_FALSE(r.joints[2].mimic);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("m.urdf:6: joint 'j3': fixed joint with <mimic joint=\"j1\">: the mimic is ignored"),
            std::string::npos) << r.warnings[0];
}

TEST(UrdfDynamics, FrictionAndDampingAreGeneralizedForces) {
  const std::string h = eom::urdf::model_header(
      eom::urdf::parse(chain3(R"(<mimic joint="j1" multiplier="-2"/><dynamics damping="3" friction="4"/>)", ""), "m.urdf"));
  for (const char* name : {"\"j1_damping\", \"j2_damping\"", "\"j1_friction\"", "\"j2_friction\"",
                           "\"friction_smoothing\""})
    EXPECT_NE(h.find(name), std::string::npos) << name << " in\n" << h;
  // j1's own, then j2's (multiplier -2: force -2 τ at rate -2 q̇)
  EXPECT_NE(h.find("Q[0] = u[0] - p[31] * qd[0] - p[33] * tanh(qd[0] / p[35]) - (-2.0) * p[32] * "
                   "(-2.0 * qd[0]) - (-2.0) * p[34] * tanh((-2.0 * qd[0]) / p[35]);"),
            std::string::npos) << h;
  EXPECT_NE(h.find("Q[1] = u[1];"), std::string::npos) << h;
}

TEST(UrdfDynamics, LimitsAreData) {
  const std::string h = eom::urdf::model_header(eom::urdf::parse(chain3("", ""), "m.urdf"));
  EXPECT_NE(h.find("std::array<double, 3> position_lower{-1.0, -unlimited, -unlimited};"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<double, 3> position_upper{2.0, unlimited, unlimited};"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<double, 3> effort_limit{30.0, unlimited, unlimited};"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<double, 3> velocity_limit{4.0, unlimited, unlimited};"), std::string::npos) << h;
}

TEST(UrdfMimic, AFollowersLimitsNarrowItsLeadersCoordinate) {
  // j1: [-1, 2], velocity 4. j2 = -2 j1 + 1 within [-2, 0.5]: j1 within [0.25, 1.5]; |2 q̇1| <= 3.
  // j3 = 0.5 j1 within [-0.25, 10]: j1 within [-0.5, 20], |0.5 q̇1| <= 1 (looser: no change).
  const auto r = eom::urdf::parse(
      chain3(R"(<limit lower="-2" upper="0.5" effort="7" velocity="3"/><mimic joint="j1" multiplier="-2" offset="1"/>)",
             R"(<limit lower="-0.25" upper="10" velocity="1"/><mimic joint="j1" multiplier="0.5"/>)"),
      "m.urdf");
  EXPECT_TRUE(r.warnings.empty());
  EXPECT_EQ(r.joints[0].lower, 0.25);
  EXPECT_EQ(r.joints[0].upper, 1.5);
  EXPECT_EQ(r.joints[0].velocity, 1.5);
  EXPECT_EQ(r.joints[0].effort, 30.0);  // the leader's own
  const std::string h = eom::urdf::model_header(r);
  EXPECT_NE(h.find("std::array<double, 1> position_lower{0.25};"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<double, 1> velocity_limit{1.5};"), std::string::npos) << h;
}

TEST(UrdfMimic, FollowerLimitsOutOfReachWarnAndKeepTheLeaders) {
  // j2 = j1 + 5 within [-1, 1] needs j1 within [-6, -4]: outside j1's [-1, 2].
  const auto r = eom::urdf::parse(
      chain3(R"(<limit lower="-1" upper="1"/><mimic joint="j1" offset="5"/>)", ""), "m.urdf");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("m.urdf:4: joint 'j2': its <limit> [-1.000000, 1.000000] cannot be met "
                               "within the limits of its leader 'j1'"),
            std::string::npos) << r.warnings[0];
  EXPECT_EQ(r.joints[0].lower, -1.0);
  EXPECT_EQ(r.joints[0].upper, 2.0);
}

namespace {

// chain3 with link c's inertia replaced, and j3 fixed when `welded` (to a, all fixed to base).
std::string bad_inertia(bool welded) {
  std::string text = chain3("", "");
  const std::string c = std::string(R"(<link name="c"><inertial><mass value="1"/>)") + kInertia;
  text.replace(text.find(c), c.size(),
               R"(<link name="c"><inertial><mass value="1"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="1e-6" ixz="1e-6" iyz="1e-6"/>)");
  if (welded) {  // c hangs from base by a fixed joint
    const std::string j3 = R"(<joint name="j3" type="continuous"><parent link="b"/>)";
    text.replace(text.find(j3), j3.size(), R"(<joint name="j3" type="fixed"><parent link="base"/>)");
  }
  return text;
}

}  // namespace

TEST(UrdfInertia, AWeldedLinkOnlyWarns) {
  const auto r = eom::urdf::parse(bad_inertia(true), "m.urdf");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("link 'c': inertia tensor violates the triangle inequality"), std::string::npos);
  EXPECT_NE(r.warnings[0].find("welded to the fixed root link 'base'"), std::string::npos) << r.warnings[0];
  EXPECT_FALSE(r.inconsistent_inertia);
  // Freed, the same link moves: an error.
  EXPECT_THROW(eom::urdf::parse(bad_inertia(true), "m.urdf", true), UrdfError);
}

TEST(UrdfInertia, AMovingLinkFollowsThePolicy) {
  using eom::urdf::InertiaPolicy;
  const std::string text = bad_inertia(false);
  try {
    eom::urdf::parse(text, "m.urdf");
    ADD_FAILURE() << "no error";
  } catch (const UrdfError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("m.urdf:", 0), 0u) << m;
    EXPECT_NE(m.find("link 'c'"), std::string::npos) << m;
    EXPECT_NE(m.find("--inertia nearest"), std::string::npos) << m;
  }
  const auto warned = eom::urdf::parse(text, "m.urdf", {.inertia = InertiaPolicy::warn});
  ASSERT_EQ(warned.warnings.size(), 1u);
  EXPECT_NE(warned.warnings[0].find("accepted as written"), std::string::npos);
  EXPECT_TRUE(warned.inconsistent_inertia);
  EXPECT_EQ(warned.links[3].inertial.inertia[3], 1e-6);
  EXPECT_NE(eom::urdf::model_header(warned).find("inconsistent_inertia_accepted = true"), std::string::npos);

  const auto nearest = eom::urdf::parse(text, "m.urdf", {.inertia = InertiaPolicy::nearest});
  ASSERT_EQ(nearest.warnings.size(), 1u);
  EXPECT_FALSE(nearest.inconsistent_inertia);
  // J = 1e-6·11ᵀ has moments (0, 0, 3e-6), the largest about n = (1, 1, 1)/√3: moved to
  // (1e-6, 1e-6, 2e-6), J' = 1e-6 (1 + nnᵀ): diagonal 4/3 e-6, off-diagonal 1/3 e-6;
  // ‖J' − J‖² = (3 (1/3)² + 6 (2/3)²) e-12 = 3e-12, ‖J‖² = 9e-12: relative change 1/√3.
  const auto& J = nearest.links[3].inertial.inertia;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(J[k], 4e-6 / 3, 1e-20);
  for (int k = 3; k < 6; ++k) EXPECT_NEAR(J[k], 1e-6 / 3, 1e-20);
  EXPECT_NE(nearest.warnings[0].find("relative change 0.577"), std::string::npos) << nearest.warnings[0];
}

TEST(UrdfInertia, NegativeAndNonFiniteStayErrors) {
  using eom::urdf::InertiaPolicy;
  std::string text = chain3("", "");
  const std::string c = std::string(R"(<link name="c"><inertial><mass value="1"/>)");
  text.replace(text.find(c), c.size(), R"(<link name="c"><inertial><mass value="-1"/>)");
  EXPECT_THROW(eom::urdf::parse(text, "m.urdf", {.inertia = InertiaPolicy::nearest}), UrdfError);
}

// A xacro file, renamed .urdf or not, is refused at its first xacro element, with the command
// that expands it (rather than "has no <link>" further on). The namespace alone is no sign (an
// expanded file often keeps it), but with no <link> the message asks whether it is xacro.
TEST(UrdfRead, AXacroFileIsRefusedWithTheCommandThatExpandsIt) {
  const std::string macro = R"(<?xml version="1.0"?>
<robot name="gen3">
  <xacro:include filename="$(find kortex_description)/arms/gen3/urdf/gen3_macro.xacro"/>
  <xacro:load_arm parent="" dof="7"/>
</robot>)";
  std::string message = error_of(macro);
  EXPECT_EQ(message.rfind("robot.urdf:3: this is a xacro file, not URDF: it has <xacro:include>", 0), 0u)
      << message;
  EXPECT_NE(message.find("xacro robot.urdf.xacro > robot.urdf"), std::string::npos) << message;
  std::string with_namespace = robot();
  with_namespace.replace(with_namespace.find("<robot name=\"r\">"), 16,
                         R"(<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">)");
  EXPECT_EQ(error_of(with_namespace), "");  // an expanded file that kept the declaration
  const std::string empty = R"(<robot name="gen3" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arm/></robot>)";
  EXPECT_EQ(error_of(empty).rfind("robot.urdf:2: this is a xacro file", 0), 0u) << error_of(empty);
  const std::string no_link = R"(<robot name="gen3" xmlns:xacro="http://www.ros.org/wiki/xacro"/>)";
  message = error_of(no_link);
  EXPECT_EQ(message.rfind("robot.urdf:1: robot 'gen3' has no <link> (it declares the xacro namespace", 0), 0u)
      << message;
  EXPECT_EQ(error_of(robot()), "");  // plain URDF is unaffected
}

// Nothing moves: the error says that a free-flying robot needs FLOATING_BASE, in each of its
// spellings; with it the same file is a free body.
TEST(UrdfRead, NoMovingJointSuggestsFloatingBase) {
  const std::string body = R"(<robot name="drone"><link name="base"><inertial><mass value="1"/>)" +
                           std::string(kInertia) + R"(</inertial></link>
  <link name="rotor"/><joint name="mount" type="fixed"><parent link="base"/><child link="rotor"/></joint>
</robot>)";
  const std::string message = error_of(body);
  EXPECT_EQ(message.rfind("robot.urdf:1: robot 'drone' has no moving joint (every joint is fixed)", 0), 0u)
      << message;
  for (const char* hint : {"add_eom_model(... FLOATING_BASE)", "eomgen.build(..., floating_base=True)",
                           "eomgen-urdf --floating-base"})
    EXPECT_NE(message.find(hint), std::string::npos) << hint << " in " << message;
  const auto free = eom::urdf::parse(body, "robot.urdf", true);
  EXPECT_TRUE(free.floating);
  EXPECT_NE(eom::urdf::model_header(free).find("floating_base = true"), std::string::npos);
}

namespace {

// The scene (add_eom_model's GROUND and COLLISION_PAIRS): `link_b` (link b's element) read with its
// <collision>s, the header written with a ground and `pairs`; the UrdfError's message, or "".
std::string scene_error_of(const std::string& link_b, const std::vector<std::string>& pairs,
                           std::string* header = nullptr) {
  try {
    const auto r = eom::urdf::parse(robot("", link_b), "robot.urdf",
                                    eom::urdf::ReadOptions{.collisions = true});
    eom::urdf::HeaderOptions options;
    options.ground = 0.25;
    options.collision_pairs = pairs;
    const std::string h = eom::urdf::model_header(r, options);
    if (header) *header = h;
  } catch (const UrdfError& e) {
    return e.what();
  }
  return "";
}
std::string link_b(const std::string& collisions) {
  return R"(<link name="b"><inertial><mass value="1"/>)" + std::string(kInertia) + "</inertial>" +
         collisions + "</link>";
}

TEST(UrdfScene, WritesGeomsGroundPairsAndLimits) {
  std::string h;
  const std::string sphere = R"(<collision name="s"><origin xyz="0 0 0.5"/><geometry><sphere radius="0.1"/></geometry></collision>)";
  ASSERT_EQ(scene_error_of(link_b(sphere + R"(<collision><geometry><box size="0.2 0.4 0.6"/></geometry></collision>)"), {}, &h), "");
  EXPECT_NE(h.find("#include <eom/multibody/scene.hpp>"), std::string::npos) << h;
  EXPECT_NE(h.find(R"({.name = "ground", .shape = eom::Shape::plane, .link = -1)"), std::string::npos) << h;
  EXPECT_NE(h.find(".position = {0.0, 0.0, 0.25}"), std::string::npos) << h;
  EXPECT_NE(h.find(R"({.name = "s", .shape = eom::Shape::sphere, .link = 1, .size = {0.1, 0.0, 0.0})"), std::string::npos) << h;
  EXPECT_NE(h.find(".shape = eom::Shape::box, .link = 1, .size = {0.1, 0.2, 0.3}"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<eom::CollisionPair, 2> collision_pairs"), std::string::npos) << h;
  EXPECT_NE(h.find("std::array<eom::JointLimit, 0> joint_limits"), std::string::npos) << h;  // no <limit>
  EXPECT_NE(h.find("damping{0.0, 0.5}"), std::string::npos) << h;
  EXPECT_NE(h.find(".timestep = 0.002"), std::string::npos) << h;
  // without the options, no scene and no <collision> read: the header as before
  const auto plain = eom::urdf::parse(robot("", link_b(R"(<collision><geometry><mesh filename="x.stl"/></geometry></collision>)")), "robot.urdf");
  EXPECT_EQ(eom::urdf::model_header(plain).find("scene"), std::string::npos);
}

// A mesh (published robots have many: HyQ 9, Romeo 20) is skipped with a warning naming the file,
// line, link and what may stand in, and named in the header; the other geoms of the robot collide,
// a cylinder (Go1 has 16) with the ground.
TEST(UrdfScene, SkipsShapesItCannotCollideWithAWarning) {
  const std::string text = robot("", link_b("\n" R"(<collision><geometry><mesh filename="b.stl"/></geometry></collision>)"
                                           "\n" R"(<collision><geometry><cylinder radius="0.1" length="1"/></geometry></collision>)"
                                           R"(<collision><geometry><sphere radius="0.1"/></geometry></collision>)"));
  const auto r = eom::urdf::parse(text, "robot.urdf", eom::urdf::ReadOptions{.collisions = true});
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0], "robot.urdf:6: link 'b': <collision> shape <mesh> skipped: only box, sphere, "
                           "capsule and cylinder collide (a box, sphere or capsule around it may stand in "
                           "for it)");
  eom::urdf::HeaderOptions options;
  options.ground = 0.0;
  std::vector<std::string> warnings;
  const std::string h = eom::urdf::model_header(r, options, &warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_NE(h.find("std::array<eom::Geom, 3> geoms"), std::string::npos) << h;  // ground, cylinder, sphere
  EXPECT_NE(h.find(".shape = eom::Shape::cylinder, .link = 1, .size = {0.1, 0.5, 0.0}"), std::string::npos) << h;
  EXPECT_NE(h.find(".rbound = 0.5099019513592785"), std::string::npos) << h;  // MuJoCo's: sqrt(r² + h²)
  EXPECT_NE(h.find("std::array<eom::CollisionPair, 2> collision_pairs"), std::string::npos) << h;
  EXPECT_NE(h.find("\n  //   robot.urdf:6 (link 'b', <mesh>)\n"), std::string::npos) << h;
  EXPECT_EQ(h.find("<cylinder>"), std::string::npos) << h;
  // without the scene, not read, no warning
  EXPECT_TRUE(eom::urdf::parse(text, "robot.urdf").warnings.empty());
}

// A cylinder against anything but the ground (COLLISION_PAIRS): MuJoCo finds those contacts by
// libccd's MPR, not reproduced; the pair is left out with a warning naming both geoms' lines and
// links, and named in the header; the link's other geoms' pairs stay.
TEST(UrdfScene, LeavesOutCylinderPairsWithAWarning) {
  std::string text = robot("", link_b("\n" R"(<collision><geometry><cylinder radius="0.1" length="1"/></geometry></collision>)"
                                      R"(<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>)"));
  const std::string a = R"(<link name="a"><inertial><mass value="1"/>)" + std::string(kInertia) + "</inertial>";
  text.replace(text.find(a), a.size(), a + R"(<collision><geometry><sphere radius="0.1"/></geometry></collision>)");
  const auto r = eom::urdf::parse(text, "robot.urdf", eom::urdf::ReadOptions{.collisions = true});
  EXPECT_TRUE(r.warnings.empty());
  eom::urdf::HeaderOptions options;
  options.ground = 0.0;
  options.collision_pairs = {"a:b"};
  std::vector<std::string> warnings;
  const std::string h = eom::urdf::model_header(r, options, &warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "robot.urdf:6: link 'b': its <cylinder> against link 'a''s <sphere> (line 4): pair "
                         "left out: a cylinder collides with the ground only (MuJoCo finds its other "
                         "contacts by libccd's iterative MPR, which eomgen does not reproduce; a capsule or "
                         "a box may stand in for it)");
  // the ground against the sphere, the cylinder and the box; the sphere against the box
  EXPECT_NE(h.find("std::array<eom::CollisionPair, 4> collision_pairs"), std::string::npos) << h;
  EXPECT_NE(h.find("\n  //   robot.urdf:6 (link 'b', <cylinder>) against link 'a''s <sphere> (line 4)\n"),
            std::string::npos) << h;
}

TEST(UrdfScene, RefusesShapesAndPairsItCannotCollide) {
  struct Case {
    const char* label;
    std::string link_b;
    std::vector<std::string> pairs;
    std::string expect;
  };
  const std::string sphere = R"(<collision><geometry><sphere radius="0.1"/></geometry></collision>)";
  const Case cases[] = {
      {"a negative radius", link_b(R"(<collision><geometry><sphere radius="-1"/></geometry></collision>)"), {},
       "link 'b': <sphere> radius must be > 0"},
      {"no geometry", link_b("<collision/>"), {}, "link 'b': <collision> has no <geometry>"},
      {"an unknown link", link_b(sphere), {"b:arm"}, "robot.urdf: COLLISION_PAIRS 'b:arm': no link 'arm' (the links: 'base', 'a', 'b')"},
      {"not a pair", link_b(sphere), {"b"}, "COLLISION_PAIRS 'b': expected <linkA>:<linkB>"},
      {"a link without collision", link_b(sphere), {"a:b"},
       "robot.urdf:4: link 'a': COLLISION_PAIRS 'a:b' names it, but it has no <collision>"},
      {"itself", link_b(sphere), {"b:b"}, "COLLISION_PAIRS 'b:b': a link against itself"},
      {"a link with a mesh alone",
       link_b(R"(<collision><geometry><mesh filename="b.stl"/></geometry></collision>)"), {"a:b"},
       "link 'a': COLLISION_PAIRS 'a:b' names it, but it has no <collision>"},
      {"a link with a mesh alone, named second",
       link_b(R"(<collision><geometry><mesh filename="b.stl"/></geometry></collision>)"), {"b:a"},
       "robot.urdf:5: link 'b': COLLISION_PAIRS 'b:a' names it, but it has no <collision> of a shape that "
       "collides (box, sphere, capsule, cylinder; its others are skipped)"},
  };
  for (const auto& c : cases) {
    const std::string message = scene_error_of(c.link_b, c.pairs);
    EXPECT_NE(message.find(c.expect), std::string::npos)
        << c.label << ": expected \"" << c.expect << "\" in \"" << message << "\"";
  }
}

}  // namespace

namespace {

// The numbers after `key` in `text` (as many as `n`, comma separated).
std::vector<double> numbers_after(const std::string& text, const std::string& key, int n) {
  std::vector<double> v;
  const std::size_t at = text.find(key);
  if (at == std::string::npos) return v;
  const char* p = text.c_str() + at + key.size();
  for (int k = 0; k < n; ++k) {
    char* end = nullptr;
    v.push_back(std::strtod(p, &end));
    p = end + 1;  // past the comma (or the closing brace)
  }
  return v;
}

// MuJoCo's inverse weights (mj_setConst) in closed form: a pendulum on a hinge about z, its mass
// centre at distance L, M = Izz + m L²: dof_invweight0 = 1/M; the link's J at its mass centre has
// the linear row (0, L, 0) and the angular (0, 0, 1), so body_invweight0 = (L²/(3M), 1/(3M)).
TEST(UrdfScene, InverseWeightsAreMuJoCosInClosedForm) {
  const double m = 2, L = 0.3, Izz = 0.05, M = Izz + m * L * L;
  const std::string text = R"(<robot name="p"><link name="base"/>
    <link name="bob"><inertial><origin xyz="0.3 0 0"/><mass value="2"/>
      <inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><origin xyz="0.3 0 0"/><geometry><sphere radius="0.05"/></geometry></collision></link>
    <joint name="swing" type="revolute"><parent link="base"/><child link="bob"/><axis xyz="0 0 1"/>
      <limit lower="-1" upper="1"/></joint></robot>)";
  eom::urdf::HeaderOptions options;
  options.ground = -1.0;
  const std::string h = eom::urdf::model_header(
      eom::urdf::parse(text, "p.urdf", eom::urdf::ReadOptions{.collisions = true}), options);
  const auto pair = numbers_after(h, ".inverse_weight = {", 2);
  ASSERT_EQ(pair.size(), 2u) << h;
  EXPECT_NEAR(pair[0], L * L / (3 * M), 1e-15);
  EXPECT_NEAR(pair[1], 1 / (3 * M), 1e-15);
  const std::size_t limits = h.find("joint_limits");
  ASSERT_NE(limits, std::string::npos) << h;
  const auto dof = numbers_after(h.substr(limits), ".inverse_weight = ", 1);
  ASSERT_EQ(dof.size(), 1u) << h;
  EXPECT_NEAR(dof[0], 1 / M, 1e-14);
  EXPECT_NE(h.find(".lower = -1.0, .upper = 1.0"), std::string::npos) << h;
  EXPECT_NE(h.find(".position = {0.0, 0.0, -1.0}"), std::string::npos) << h;  // the ground
}

}  // namespace
