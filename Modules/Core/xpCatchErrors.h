/**
 * @file xpCatchErrors.h
 * @brief For filter methods called from Python, where a C++ exception would end the
 *        interpreter: an xp::Error becomes `false`, its text for GetLastError(), and a VTK error.
 */
#ifndef xpCatchErrors_h
#define xpCatchErrors_h

#include "xpError.h"

#include <vtkObject.h>
#include <vtkSetGet.h>

#include <string>

namespace xp
{

template <typename Body>
bool CatchErrors(vtkObject* object, std::string& lastError, Body&& body)
{
  try
  {
    body();
    return true;
  }
  catch (const Error& e)
  {
    lastError = e.what();
    vtkErrorWithObjectMacro(object, << e.what());
    return false;
  }
}

} // namespace xp

#endif
