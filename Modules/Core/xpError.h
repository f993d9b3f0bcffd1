/**
 * @file xpError.h
 * @brief The one exception type of xpose's plain C++ layer.
 *
 * Kernels and readers throw xp::Error with a message that names the file and the field at
 * fault; VTK filters catch it and turn it into vtkErrorMacro; only applications decide how to
 * exit. Nothing in Modules/ prints or calls exit().
 */
#ifndef xpError_h
#define xpError_h

#include "vtkXPCoreModule.h"

#include <stdexcept>
#include <string>

namespace xp
{

class VTKXPCORE_EXPORT Error : public std::runtime_error
{
public:
  explicit Error(const std::string& message);
  /** "where: what", where is a file, a field or both ("geometry.json: imagers[0].source"). */
  Error(const std::string& where, const std::string& what);
};

/** Bad input from the user (file, field, option): applications exit with code 2. */
class VTKXPCORE_EXPORT InputError : public Error
{
public:
  using Error::Error;
};

} // namespace xp

#endif
