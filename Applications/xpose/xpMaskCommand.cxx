#include "xpCommands.h"

#include "vtkXPEntropyMaskFilter.h"
#include "xpError.h"
#include "xpDICOMXRay.h"
#include "xpImageIO.h"

#include <vtkImageData.h>
#include <vtkNew.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace xp
{

int RunMask(const MaskOptions& options)
{
  // The filter clamps out-of-range values; a command refuses them instead.
  CheckLimit(options.window, 3, 63, "--window");
  CheckLimit(options.binWidth, 1, 4095, "--bin-width");
  vtkSmartPointer<vtkImageData> xray = ReadXRayImage(options.xray);
  int dims[3];
  xray->GetDimensions(dims);
  vtkSmartPointer<vtkImageData> roi;
  if (!options.roi.empty())
  {
    roi = ReadMaskPNG(options.roi, dims[0], dims[1]);
  }
  // Method.md's mask bins 12-bit values; a deeper X-ray is scaled to 12 bits. (`register` takes
  // its masks in the DRR's transmission domain, which needs the CT: Algorithms.md.)
  const size_t count = static_cast<size_t>(dims[0]) * dims[1];
  auto* values = static_cast<uint16_t*>(xray->GetScalarPointer());
  const uint16_t brightest = count ? *std::max_element(values, values + count) : 0;
  if (brightest > 4095)
    for (size_t i = 0; i < count; ++i)
      values[i] = static_cast<uint16_t>(std::lround(values[i] * 4095.0 / brightest));
  vtkNew<vtkXPEntropyMaskFilter> filter;
  filter->SetInputData(0, xray);
  filter->SetInputData(1, roi);
  filter->SetWindowSize(options.window);
  filter->SetBinWidth(options.binWidth);
  filter->Update();
  if (filter->GetOutput(0)->GetNumberOfPoints() == 0)
  {
    throw InputError(options.xray, "the entropy mask could not be computed (see the message above)");
  }
  if (filter->GetValidFraction() == 0.0)
  {
    throw InputError(options.xray, "the mask is empty: no region holds enough information to register");
  }
  // 8-bit entropy map, entropy x 255.
  vtkNew<vtkImageData> entropy;
  entropy->CopyStructure(filter->GetOutput(1));
  entropy->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  const auto* h = static_cast<const float*>(filter->GetOutput(1)->GetScalarPointer());
  auto* e = static_cast<uint8_t*>(entropy->GetScalarPointer());
  for (vtkIdType i = 0; i < entropy->GetNumberOfPoints(); ++i)
  {
    e[i] = static_cast<uint8_t>(std::lround(255.0 * std::min(1.0f, std::max(0.0f, h[i]))));
  }
  StagedOutputDirectory output(options.outputDirectory);
  WritePNG(filter->GetOutput(0), output.Path("mask.png"));
  WritePNG(entropy, output.Path("entropy.png"));
  output.Commit();
  std::printf("%s: %dx%d, image entropy H(X) = %.4f, valid fraction %.4f; wrote mask.png and entropy.png to %s\n",
    options.xray.c_str(), dims[0], dims[1], filter->GetImageEntropy(), filter->GetValidFraction(),
    options.outputDirectory.c_str());
  return ExitOk;
}

} // namespace xp
