#include "xpDetector.h"

#include "xpError.h"

#include <vtkSMPTools.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace xp
{

namespace
{

/** Open-field grey level of the linear formats: 88 % of full scale leaves headroom for the heel
 *  and for noise. */
constexpr double OpenFieldShare = 3600.0 / 4095.0;
/** The log formats' full scale: -ln(I / I0) from 0 to 10. */
constexpr double LogScale = 10.0;

double Percentile(std::vector<float> values, double q)
{
  if (values.empty())
    return 0.0;
  const size_t rank = static_cast<size_t>(q * (values.size() - 1));
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  return values[rank];
}

/** The processed format's image, 0..1, from -ln(I / I0). */
std::vector<float> PresentationImage(std::vector<float> logImage, int columns, int rows, double pixelSpacingMM)
{
  std::vector<float> low = logImage;
  GaussianBlur(low, columns, rows, 10.0 / pixelSpacingMM);
  for (size_t i = 0; i < logImage.size(); ++i)
    logImage[i] += 1.0f * (logImage[i] - low[i]);
  const double lowest = Percentile(logImage, 0.005), highest = Percentile(logImage, 0.995);
  const double width = std::max(highest - lowest, 1e-6);
  for (float& v : logImage)
    v = static_cast<float>(std::pow(std::clamp((v - lowest) / width, 0.0, 1.0), 0.8));
  return logImage;
}

} // namespace

const char* DetectorFormatName(DetectorFormat format)
{
  switch (format)
  {
    case DetectorFormat::Linear12:
      return "linear12";
    case DetectorFormat::Linear16:
      return "linear16";
    case DetectorFormat::Log:
      return "log";
    case DetectorFormat::Processed:
      return "processed";
  }
  return "unknown";
}

DetectorFormat ParseDetectorFormat(const std::string& name, const std::string& option)
{
  for (DetectorFormat format : { DetectorFormat::Linear12, DetectorFormat::Linear16, DetectorFormat::Log, DetectorFormat::Processed })
    if (name == DetectorFormatName(format))
      return format;
  throw InputError(option, "expected linear12, linear16, log or processed, got '" + name + "'");
}

int DetectorMaxValue(DetectorFormat format)
{
  switch (format)
  {
    case DetectorFormat::Linear16:
      return 65535;
    case DetectorFormat::Processed:
      return 255;
    default:
      return 4095;
  }
}

void DetectorSettings::Validate() const
{
  if (!(this->quanta >= 0.0 && this->quanta <= 1e9))
    throw InputError("--dose", "quanta per pixel at full transmission must be between 0 and 1e9");
  if (!(this->electronicNoise >= 0.0 && this->electronicNoise <= 0.5))
    throw InputError("--electronic-noise", "must be between 0 and 0.5 of the open field");
}

std::string DetectorSettings::Describe() const
{
  std::ostringstream text;
  text << "{ \"format\": \"" << DetectorFormatName(this->format) << "\", \"quanta_per_pixel\": " << this->quanta
       << ", \"electronic_noise\": " << this->electronicNoise << " }";
  return text.str();
}

std::vector<uint16_t> DetectImage(const std::vector<float>& signal, int columns, int rows, double pixelSpacingMM,
  const DetectorSettings& settings, std::mt19937& random)
{
  std::vector<float> measured = signal;
  std::normal_distribution<double> electronic(0.0, 1.0);
  for (float& s : measured)
  {
    double value = std::max(0.0, static_cast<double>(s));
    if (settings.quanta > 0.0)
    {
      std::poisson_distribution<long long> counts(value * settings.quanta);
      value = counts(random) / settings.quanta;
    }
    if (settings.electronicNoise > 0.0)
      value += settings.electronicNoise * electronic(random);
    s = static_cast<float>(value);
  }
  const double top = DetectorMaxValue(settings.format);
  std::vector<float> grey(measured.size());
  if (settings.format == DetectorFormat::Linear12 || settings.format == DetectorFormat::Linear16)
  {
    for (size_t i = 0; i < grey.size(); ++i)
      grey[i] = static_cast<float>(OpenFieldShare * top * measured[i]);
  }
  else
  {
    // A panel's log conversion cannot see through zero counts: the floor is a tenth of a quantum.
    const double floor = settings.quanta > 0.0 ? 0.1 / settings.quanta : 1e-6;
    for (size_t i = 0; i < grey.size(); ++i)
      grey[i] = static_cast<float>(-std::log(std::max(static_cast<double>(measured[i]), floor)));
    if (settings.format == DetectorFormat::Processed)
      grey = PresentationImage(std::move(grey), columns, rows, pixelSpacingMM);
    const double scale = settings.format == DetectorFormat::Processed ? top : top / LogScale;
    for (float& g : grey)
      g = static_cast<float>(g * scale);
  }
  std::vector<uint16_t> image(grey.size());
  for (size_t i = 0; i < image.size(); ++i)
    image[i] = static_cast<uint16_t>(std::clamp(std::lround(grey[i]), 0L, static_cast<long>(top)));
  return image;
}

/** Separable Gaussian blur of a columns x rows image, edges replicated. */
void GaussianBlur(std::vector<float>& image, int columns, int rows, double sigmaPixels)
{
  if (!(sigmaPixels > 0.05))
    return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigmaPixels)));
  std::vector<float> kernel(2 * radius + 1);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i)
    sum += kernel[i + radius] = static_cast<float>(std::exp(-0.5 * i * i / (sigmaPixels * sigmaPixels)));
  for (float& k : kernel)
    k = static_cast<float>(k / sum);
  std::vector<float> out(image.size());
  const auto pass = [&](bool alongRows)
  {
    const int length = alongRows ? columns : rows, lines = alongRows ? rows : columns;
    vtkSMPTools::For(0, lines, [&](int first, int last)
      {
        for (int l = first; l < last; ++l)
          for (int i = 0; i < length; ++i)
          {
            float value = 0.0f;
            for (int k = -radius; k <= radius; ++k)
            {
              const int j = std::clamp(i + k, 0, length - 1);
              value += kernel[k + radius] * (alongRows ? image[static_cast<size_t>(l) * columns + j] : image[static_cast<size_t>(j) * columns + l]);
            }
            (alongRows ? out[static_cast<size_t>(l) * columns + i] : out[static_cast<size_t>(i) * columns + l]) = value;
          }
      });
    image.swap(out);
  };
  pass(true);
  pass(false);
}

} // namespace xp
