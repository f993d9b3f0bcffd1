/**
 * @file xpVirtualDisplay.h
 * @brief An X display for VTK's off-screen rendering on a machine without one.
 *
 * Debian's VTK is built for X11 only, and Render() aborts the process when no X server answers
 * (BUILD-NOTES.md). Before rendering, call VirtualDisplay::Ensure(): it keeps a working DISPLAY,
 * or starts a private Xvfb on a free display number and stops it when the object goes away.
 */
#ifndef xpVirtualDisplay_h
#define xpVirtualDisplay_h

#include "vtkXPReportingModule.h"

#include <memory>
#include <string>

namespace xp
{

class VTKXPREPORTING_EXPORT VirtualDisplay
{
public:
  /**
   * A display to render on: the current one when its server answers, else a new Xvfb. Returns
   * nullptr and says why in `reason` when neither is possible (no Xvfb installed, say).
   */
  static std::unique_ptr<VirtualDisplay> Ensure(std::string& reason);

  ~VirtualDisplay();
  VirtualDisplay(const VirtualDisplay&) = delete;
  VirtualDisplay& operator=(const VirtualDisplay&) = delete;

  /** ":N", the display in use. */
  const std::string& Name() const { return this->Display; }
  /** True when this object started the server (and will stop it). */
  bool Started() const { return this->ServerProcess > 0; }

private:
  VirtualDisplay() = default;

  std::string Display;
  std::string PreviousDisplay;
  bool HadDisplay = false;
  int ServerProcess = 0;
};

/** Whether an X server answers on `display` (":N", ":N.S" or "host:N"). */
VTKXPREPORTING_EXPORT bool DisplayAnswers(const std::string& display);

} // namespace xp

#endif
