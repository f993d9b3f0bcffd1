#include "xpError.h"

namespace xp
{

Error::Error(const std::string& message)
  : std::runtime_error(message)
{
}

Error::Error(const std::string& where, const std::string& what)
  : std::runtime_error(where.empty() ? what : where + ": " + what)
{
}

} // namespace xp
