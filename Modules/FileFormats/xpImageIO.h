/**
 * @file xpImageIO.h
 * @brief Output of detector images (PNG 8/16-bit, MetaImage float with its Room placement) and
 *        an output folder that is written completely or not at all.
 *
 * Detector images in xpose's VTK pipelines store rows bottom-up (VTK's j runs up): VTK row j
 * holds detector row rows-1-j. PNG files keep row 0 = detector row 0 at the top.
 */
#ifndef xpImageIO_h
#define xpImageIO_h

#include "vtkXPFileFormatsModule.h"

#include <vtkSmartPointer.h>

#include <string>
#include <vector>

class vtkImageData;

namespace xp
{
struct XRayView;

/** Writes an unsigned char or unsigned short 2D image as PNG (top row = detector row 0). */
VTKXPFILEFORMATS_EXPORT void WritePNG(vtkImageData* image, const std::string& path);

/**
 * Writes a float 2D detector image as MetaImage: pixel (i, j) = detector column i, row j, placed
 * in Room coordinates by Offset/TransformMatrix of `view` (a 3D image one pixel deep).
 */
VTKXPFILEFORMATS_EXPORT void WriteDetectorMetaImage(vtkImageData* image, const XRayView& view, const std::string& path);

/**
 * Reads a validity mask (PNG, non-zero = valid) for a detector of columns x rows, returned in
 * VTK row order as unsigned char 0/1. Throws xp::InputError naming the file when it cannot be
 * read, its size differs, or no pixel is valid.
 */
VTKXPFILEFORMATS_EXPORT vtkSmartPointer<vtkImageData> ReadMaskPNG(const std::string& path, int columns, int rows);

/**
 * Reads an X-ray stored as a grey PNG of any bit depth (8-bit processed, 12-bit in 16, a panel's
 * raw 16), values as stored, in VTK row order. Throws xp::InputError naming the file when it is
 * unreadable or not grey with one channel.
 */
VTKXPFILEFORMATS_EXPORT vtkSmartPointer<vtkImageData> ReadXRayPNG(const std::string& path);

/**
 * Reads an X-ray stored as a grey one-page TIFF, 8 or 16 bits (white-is-zero turned round),
 * values as stored, in VTK row order. Throws xp::InputError naming the file when it is
 * unreadable, not grey, tiled, or holds more than one page.
 */
VTKXPFILEFORMATS_EXPORT vtkSmartPointer<vtkImageData> ReadXRayTIFF(const std::string& path);

/** The MD5 of a file's bytes as 32 hex digits: identifies an input file in a result record. */
VTKXPFILEFORMATS_EXPORT std::string FileMD5(const std::string& path);

/**
 * Collects output files in a hidden staging folder inside `directory` and moves them into place
 * only on Commit(): a command that fails half-way leaves nothing half-written behind.
 */
class VTKXPFILEFORMATS_EXPORT StagedOutputDirectory
{
public:
  /** Creates `directory` if needed and a staging folder in it; throws xp::InputError if it cannot. */
  explicit StagedOutputDirectory(const std::string& directory);
  ~StagedOutputDirectory();
  StagedOutputDirectory(const StagedOutputDirectory&) = delete;
  StagedOutputDirectory& operator=(const StagedOutputDirectory&) = delete;

  /**
   * Checks, without creating anything, that `directory` is a writable folder or could be
   * created as one; throws xp::InputError naming it otherwise. For checks before long work.
   */
  static void CheckWritable(const std::string& directory);

  /** Where to write `fileName` now (inside the staging folder); records the name, so call it
   *  from one thread (the writing itself may happen on others). */
  std::string Path(const std::string& fileName);
  /** The staging folder itself, for writers that create files by name; register each with Track. */
  const std::string& StagingFolder() const { return this->Staging; }
  void Track(const std::string& fileName) { this->Names.push_back(fileName); }
  /**
   * Files already in the directory that match one of these patterns (fnmatch, e.g.
   * "entropy_*.png") and that this run does not write are removed on Commit, so that a folder
   * never mixes the outputs of two runs.
   */
  void ReplaceEarlier(const std::vector<std::string>& patterns) { this->EarlierPatterns = patterns; }
  /**
   * Moves the staged files into the directory in the order they were added, replacing older
   * files of the same name. Add the record that marks a complete output (result.json) last:
   * its older copy is removed before anything moves, and the new one arrives after the rest.
   */
  void Commit();

  const std::string& Directory() const { return this->Final; }

private:
  std::string Final;
  std::string Staging;
  std::vector<std::string> Names;
  std::vector<std::string> EarlierPatterns;
  bool Committed = false;
};

} // namespace xp

#endif
