#include "xpEigenVTK.h"
#include "xpError.h"

#include <gtest/gtest.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>

TEST(EigenVTK, RoundTripKeepsRotationAndTranslation)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  t.translation() = Eigen::Vector3d(4, -5, 6);
  vtkNew<vtkMatrix4x4> m;
  xp::ToVTK(t, m);
  EXPECT_DOUBLE_EQ(m->GetElement(1, 3), -5.0);
  EXPECT_DOUBLE_EQ(m->GetElement(0, 1), t.linear()(0, 1));
  EXPECT_TRUE(xp::FromVTK(m).isApprox(t, 1e-15));
}

TEST(Error, NamesWhereAndWhat)
{
  EXPECT_STREQ(xp::Error("file.json: field", "is bad").what(), "file.json: field: is bad");
}
