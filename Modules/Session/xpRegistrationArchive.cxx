#include "xpRegistrationArchive.h"

#include "xpDICOMArchive.h"

#include <algorithm>
#include <filesystem>

namespace xp
{

ArchivedInputs FetchRegistrationInputs(const DICOMArchive& archive, const std::string& study, const std::string& ctSeries,
  const std::vector<std::string>& xrayInstances, const std::string& folder)
{
  ArchivedInputs fetched;
  fetched.ctSeries = ctSeries.empty() ? archive.CTSeriesOfStudy(study) : ctSeries;
  std::filesystem::remove_all(folder);
  fetched.ctFolder = folder + "/ct";
  std::filesystem::create_directories(fetched.ctFolder);
  archive.FetchSeries(fetched.ctSeries, fetched.ctFolder);
  for (size_t v = 0; v < xrayInstances.size(); ++v)
  {
    fetched.xrays.push_back(folder + "/xray_" + std::to_string(v + 1) + ".dcm");
    archive.FetchInstance(xrayInstances[v], fetched.xrays.back());
  }
  return fetched;
}

std::vector<std::string> StoreRegistrationDICOM(const DICOMArchive& archive, const std::string& directory)
{
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(directory))
    if (entry.path().extension() == ".dcm" && entry.path().filename() != "reg.dcm")
      files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  if (std::filesystem::exists(directory + "/reg.dcm"))
    files.push_back(directory + "/reg.dcm");
  archive.Store(files);
  return files;
}

} // namespace xp
