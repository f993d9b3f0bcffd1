// multipart/related as DICOMweb uses it: what JoinMultipart writes SplitMultipart reads back,
// part for part; a quoted boundary is found; a body cut short or without its boundary is refused.
#include "xpError.h"
#include "xpMultipart.h"

#include <gtest/gtest.h>

TEST(Multipart, PartsComeBackAsTheyWentIn)
{
  const std::string binary("DICM\0\r\n--not-the-boundary\r\n\xff", 29);
  const std::vector<std::string> parts = { "first", binary, "" };
  const std::string boundary = xp::NewBoundary();
  const std::vector<xp::MultipartPart> back =
    xp::SplitMultipart(xp::JoinMultipart(parts, "application/dicom", boundary), boundary, "test");
  ASSERT_EQ(back.size(), parts.size());
  for (size_t i = 0; i < parts.size(); ++i)
  {
    EXPECT_EQ(back[i].body, parts[i]) << i;
    EXPECT_EQ(back[i].contentType, "application/dicom") << i;
  }
  EXPECT_NE(xp::NewBoundary(), boundary);
  // A part that holds the boundary cannot be framed by it.
  EXPECT_THROW(xp::JoinMultipart({ "a --" + boundary + " b" }, "application/dicom", boundary), xp::Error);
}

TEST(Multipart, ContentTypeParametersQuotedOrNot)
{
  const std::string type = "multipart/related; type=\"application/dicom; x=1\"; Boundary=\"abc;def\"";
  EXPECT_EQ(xp::ContentTypeParameter(type, "boundary"), "abc;def");
  EXPECT_EQ(xp::ContentTypeParameter(type, "type"), "application/dicom; x=1");
  EXPECT_EQ(xp::ContentTypeParameter("multipart/related;boundary=xyz", "boundary"), "xyz");
  EXPECT_EQ(xp::ContentTypeParameter("application/dicom", "boundary"), "");
}

TEST(Multipart, APreambleAndHeadersAreReadAndBrokenBodiesRefused)
{
  const std::string body = "preamble\r\n--b\r\nContent-Type: application/dicom\r\nContent-Length: 3\r\n\r\nabc\r\n"
                           "--b\r\n\r\nxyz\r\n--b--\r\n";
  const std::vector<xp::MultipartPart> parts = xp::SplitMultipart(body, "b", "test");
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].body, "abc");
  EXPECT_EQ(parts[0].contentType, "application/dicom");
  EXPECT_EQ(parts[1].body, "xyz");
  EXPECT_EQ(parts[1].contentType, "");
  EXPECT_THROW(xp::SplitMultipart("no boundary here", "b", "test"), xp::Error);
  EXPECT_THROW(xp::SplitMultipart("--b\r\n\r\nabc", "b", "test"), xp::Error);          // cut short
  EXPECT_THROW(xp::SplitMultipart("--b\r\nContent-Type: x\r\nabc\r\n--b--", "b", "test"), xp::Error); // no blank line
  EXPECT_THROW(xp::SplitMultipart(body, "", "test"), xp::Error);
}
