#include "xpReferenceGeometry.h"

#include "xpError.h"

#include <fstream>
#include <gtest/gtest.h>

namespace
{

const char* ReferenceText = R"({
  "name": "stereo-oblique-90", "isocenter": [0, 0, 0],
  "imagers": [
    { "name": "A", "source": [-707.107, 0, -707.107],
      "detector": { "center": [353.553, 0, 353.553], "row_direction": [-0.707107, 0, 0.707107],
        "column_direction": [0, -1, 0], "pixel_spacing": [0.390625, 0.390625], "size": [1024, 768] } },
    { "name": "B", "source": [707.107, 0, -707.107],
      "detector": { "center": [-353.553, 0, 353.553], "row_direction": [-0.707107, 0, -0.707107],
        "column_direction": [0, -1, 0], "pixel_spacing": [0.390625, 0.390625], "size": [1024, 768] } } ] })";

std::string Replace(std::string text, const std::string& from, const std::string& to)
{
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

/** The message of the InputError that parsing `text` throws, or "" if it parses. */
std::string ParseError(const std::string& text)
{
  try
  {
    xp::ParseStereoGeometry(text, "g.json");
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}

} // namespace

TEST(StereoGeometryFile, ParsesTheReferenceFile)
{
  const xp::StereoGeometry g = xp::ParseStereoGeometry(ReferenceText, "g.json");
  ASSERT_EQ(g.views.size(), 2u);
  EXPECT_EQ(g.views[1].name, "B");
  EXPECT_EQ(g.views[0].size, Eigen::Vector2i(1024, 768));
  EXPECT_NEAR(g.views[1].rowDirection[2], -std::sqrt(0.5), 1e-12); // normalised on read
  EXPECT_NO_THROW(xp::ValidateStereoGeometry(g, "g.json"));
}

TEST(StereoGeometryFile, WriteThenReadIsIdentity)
{
  const xp::StereoGeometry g = xp::testing::ReferenceStereoGeometry();
  const std::string path = "roundtrip-geometry.json";
  xp::WriteStereoGeometry(g, path);
  const xp::StereoGeometry back = xp::ReadStereoGeometry(path);
  ASSERT_EQ(back.views.size(), 2u);
  for (int v = 0; v < 2; ++v)
  {
    EXPECT_EQ(back.views[v].name, g.views[v].name);
    EXPECT_EQ(back.views[v].source, g.views[v].source);
    EXPECT_TRUE(back.views[v].rowDirection.isApprox(g.views[v].rowDirection, 1e-6)); // normalised on read
    EXPECT_EQ(back.views[v].pixelSpacing, g.views[v].pixelSpacing);
  }
  std::remove(path.c_str());
}

TEST(StereoGeometryFile, ErrorsNameTheField)
{
  EXPECT_NE(ParseError(Replace(ReferenceText, "[-0.707107, 0, 0.707107]", "[-0.8, 0, 0.707107]"))
              .find("g.json: imagers[0].detector.row_direction: not a unit vector"),
    std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"column_direction\": [0, -1, 0]", "\"column_direction\": [0.707107, -0.707107, 0]"))
              .find("imagers[0].detector.column_direction: not orthogonal"),
    std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"size\": [1024, 768] } } ]", "\"size\": [1024] } } ]"))
              .find("imagers[1].detector.size: expected an array of 2"),
    std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"source\": [707.107, 0, -707.107]", "\"source\": [-353.553, 0, 353.553]"))
              .find("imagers[1].source: lies on the panel plane"),
    std::string::npos);
  // Panel shifted sideways by 300 mm: the central ray misses it.
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"center\": [353.553, 0, 353.553]", "\"center\": [353.553, 300, 353.553]"))
              .find("imagers[0].detector.center: the ray from the source through the isocentre misses the panel"),
    std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"name\": \"B\"", "\"name\": \"A\"")).find("imagers[1].name: duplicate"),
    std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"pixel_spacing\": [0.390625, 0.390625], \"size\": [1024, 768] } } ]",
                         "\"pixel_spacing\": [0, 0.390625], \"size\": [1024, 768] } } ]"))
              .find("imagers[1].detector.pixel_spacing: must be positive"),
    std::string::npos);
  EXPECT_NE(ParseError("{ \"imagers\": [ ").find("g.json: not valid JSON"), std::string::npos);
  EXPECT_NE(ParseError(Replace(ReferenceText, "\"source\": [-707.107, 0, -707.107],", "")).find("imagers[0].source: missing"),
    std::string::npos);
}

TEST(StereoGeometryFile, StereoNeedsTwoImagers)
{
  xp::StereoGeometry g = xp::testing::ReferenceStereoGeometry();
  g.views.pop_back();
  EXPECT_NO_THROW(xp::ValidateGeometry(g, "g.json"));
  EXPECT_THROW(xp::ValidateStereoGeometry(g, "g.json"), xp::InputError);
  EXPECT_THROW(xp::ReadStereoGeometry("no-such-file.json"), xp::InputError);
}
