#include "xpWholeFile.h"

#include "xpError.h"

#include <cstdio>
#include <fstream>
#include <sstream>

namespace xp
{

std::string ReadWholeFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(path, "cannot be read");
  std::ostringstream text;
  text << in.rdbuf(); // an empty file inserts nothing and sets text's failbit: not an error
  if (in.bad())
    throw InputError(path, "cannot be read");
  return text.str();
}

void WriteWholeFile(const std::string& path, const std::string& text)
{
  const std::string partial = path + ".partial";
  std::ofstream out(partial, std::ios::binary);
  out << text;
  out.close();
  if (!out || std::rename(partial.c_str(), path.c_str()) != 0)
  {
    std::remove(partial.c_str());
    throw Error(path, "cannot write");
  }
}

} // namespace xp
