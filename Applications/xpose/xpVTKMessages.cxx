// VTK's warnings and errors as one plain line each on stderr (see RouteVTKMessages).
#include "xpCommands.h"

#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkOutputWindow.h>

#include <cstdio>
#include <string>

namespace
{

/**
 * VTK formats a message as "ERROR: In FILE, line N\nCLASS (0x..): TEXT\n<object dump>": the
 * user needs TEXT. A failed request that follows an error xpose reports itself adds nothing.
 */
class vtkXPOneLineOutputWindow : public vtkOutputWindow
{
public:
  static vtkXPOneLineOutputWindow* New();
  vtkTypeMacro(vtkXPOneLineOutputWindow, vtkOutputWindow);

  void DisplayErrorText(const char* text) override { Print("error", text); }
  void DisplayWarningText(const char* text) override { Print("warning", text); }
  void DisplayGenericWarningText(const char* text) override { Print("warning", text); }
  void DisplayDebugText(const char*) override {}
  void DisplayText(const char* text) override { Print("message", text); }

private:
  static void Print(const char* kind, const char* text)
  {
    std::string message = text ? text : "";
    if (message.find("returned failure for request") != std::string::npos)
    {
      return;
    }
    if (message.rfind("ERROR: In ", 0) == 0 || message.rfind("Warning: In ", 0) == 0)
    {
      message = message.substr(message.find('\n') + 1);
    }
    message = message.substr(0, message.find('\n'));
    const size_t object = message.find("): ");
    if (object != std::string::npos && message.find(" (0x") < object)
    {
      message = message.substr(0, message.find(" (0x")) + ": " + message.substr(object + 3);
    }
    std::fprintf(stderr, "xpose: VTK %s: %s\n", kind, message.c_str());
  }
};

vtkStandardNewMacro(vtkXPOneLineOutputWindow);

} // namespace

namespace xp
{

void RouteVTKMessages()
{
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  vtkNew<vtkXPOneLineOutputWindow> window;
  window->SetDisplayModeToAlways();
  vtkOutputWindow::SetInstance(window);
}

} // namespace xp
