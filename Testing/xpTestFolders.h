// A fresh, empty folder per test under the test's working directory.
#ifndef xpTestFolders_h
#define xpTestFolders_h

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace xp::testing
{

inline std::string FreshFolder(const std::string& name)
{
  const std::string path = "tmp-" + name;
  const std::string command = "rm -rf '" + path + "' && mkdir -p '" + path + "'";
  EXPECT_EQ(std::system(command.c_str()), 0);
  return path;
}

} // namespace xp::testing

#endif
