/**
 * @file xpWholeFile.h
 * @brief A small file read or written in one piece: geometry files, result records, settings.
 */
#ifndef xpWholeFile_h
#define xpWholeFile_h

#include "vtkXPCoreModule.h"

#include <string>

namespace xp
{

/** The bytes of the file at `path`; throws xp::InputError naming it when it cannot be read. */
VTKXPCORE_EXPORT std::string ReadWholeFile(const std::string& path);

/** Writes `text` to `path` through a .partial file, so that `path` is never half-written;
 *  throws xp::Error naming it when it cannot be written. */
VTKXPCORE_EXPORT void WriteWholeFile(const std::string& path, const std::string& text);

} // namespace xp

#endif
