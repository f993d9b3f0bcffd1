/**
 * @class vtkXPRegistrationSession
 * @brief A registration session for Python (and any VTK program): the files a registration reads
 *        in, the result.json record and result folder out, by the code `xpose register` runs.
 *
 * Name the CT, the geometry and one X-ray per imager (and optionally ROIs, the registration size,
 * a start pose), then Run(). The inputs are read and checked exactly as `xpose register` reads
 * them (xp::RegistrationSession): the same files with the same options give the same pose and
 * verdict. The filter underneath, vtkXPStereoRegistrationFilter, is there for pipelines that hold
 * their images in memory.
 *
 *     session = xpose.vtkXPRegistrationSession()
 *     session.SetCTPath("ct"); session.SetGeometryPath("geometry.json")
 *     session.AddXRayPath("xray_A.png"); session.AddXRayPath("xray_B.png")
 *     session.SetSize("256x192")
 *     status = session.Run()  # 1 ok, 0 failed, -1 refused input (GetLastError says why)
 *     record = json.loads(session.GetResultJSON())
 */
#ifndef vtkXPRegistrationSession_h
#define vtkXPRegistrationSession_h

#include "vtkXPSessionModule.h"

#include <vtkObject.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace xp
{
class RegistrationSession;
}

class VTKXPSESSION_EXPORT vtkXPRegistrationSession : public vtkObject
{
public:
  static vtkXPRegistrationSession* New();
  vtkTypeMacro(vtkXPRegistrationSession, vtkObject);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /** The sources, as `xpose register`'s options name them (--ct, --series, --voxel-size,
   *  --geometry, --xray, --roi, --size, --iso-ct, --mu-water, --remove-table). */
  void SetCTPath(const std::string& path) { this->CTPath = path; }
  void SetSeries(const std::string& uid) { this->Series = uid; }
  void SetVoxelSize(const std::string& xyz) { this->VoxelSize = xyz; }
  void SetGeometryPath(const std::string& path) { this->GeometryPath = path; }
  void AddXRayPath(const std::string& path) { this->XRayPaths.push_back(path); }
  void AddROIPath(const std::string& path) { this->ROIPaths.push_back(path); }
  void RemoveAllXRayAndROIPaths();
  void SetSize(const std::string& columnsXRows) { this->Size = columnsXRows; }
  void SetIsocenterInCT(const std::string& xyz) { this->IsocenterInCT = xyz; }
  void SetMuWater(double perMM) { this->MuWater = perMM; }
  ///@}

  ///@{
  /** The CT's table, as register's options: by default the CT with its table or the body alone,
   *  whichever the X-rays match better (--choose-table; result.json `table`); SetKeepTable renders
   *  the CT as it is (--keep-table), SetRemoveTable the body alone (--remove-table); either with
   *  false restores the default. Choosing and removing at once is refused by Run. */
  void SetChooseTable(bool on) { this->ChooseTable = on; }
  void SetKeepTable(bool on)
  {
    this->ChooseTable = !on;
    this->RemoveTable = false;
  }
  void SetRemoveTable(bool on)
  {
    this->RemoveTable = on;
    this->ChooseTable = !on;
  }
  ///@}

  /** Where the search starts (--initial-pose: tx, ty, tz mm, pitch, roll, yaw degrees); zero:
   *  the planned set-up. */
  void SetInitialPose(double tx, double ty, double tz, double pitch, double roll, double yaw);
  /** The 6-DOF stages' optimiser (--optimizer): one name, or SEARCH/REFINEMENT. */
  void SetOptimizer(const std::string& name) { this->Optimizer = name; }
  /** Entropy masks on (the default) or the whole images. */
  void SetEntropyMask(bool on) { this->EntropyMask = on; }
  /** Where the rays are cast (--device): "cpu" (the default), "cuda" (refused by Run where no GPU
   *  can run it) or "auto". */
  void SetDevice(const std::string& device) { this->Device = device; }
  /** The registration's schedule (--schedule): "economy" (the default) or "standard"; anything
   *  else is refused by Run. */
  void SetSchedule(const std::string& schedule) { this->Schedule = schedule; }

  ///@{
  /** The couch that carries out an ok result and the clinic's action levels, as `xpose register`
   *  names them (--couch 6dof|4dof, --couch-rotation-limit, --target "x,y,z" in the CT's LPS mm,
   *  --action-level-mm/-deg, --max-uncorrected-mm/-deg); result.json's `couch` gives the motion.
   *  A value out of range is refused by Run, naming the option. */
  void SetCouch(const std::string& motions) { this->CouchMotions = motions; }
  void SetCouchRotationLimit(double degrees) { this->CouchRotationLimit = std::to_string(degrees); }
  void SetTarget(const std::string& xyz) { this->Target = xyz; }
  void SetActionLevels(double mm, double degrees)
  {
    this->ActionLevel[0] = mm;
    this->ActionLevel[1] = degrees;
  }
  void SetMaxUncorrected(double mm, double degrees)
  {
    this->MaxUncorrected[0] = mm;
    this->MaxUncorrected[1] = degrees;
  }
  ///@}

  /**
   * Reads the inputs, registers, and keeps the result: 1 when it is ok (the couch may be moved by
   * its correction), 0 when it failed the quality gate, -1 when an input was refused (GetLastError
   * names the file or the option; nothing is registered).
   */
  int Run();
  /** After Run: result.json's record, inputs included. Empty before a successful Run. */
  std::string GetResultJSON() const;
  /** The last refusal, "FILE_OR_OPTION: why"; empty when Run succeeded. */
  const char* GetLastError() const { return this->LastError.c_str(); }
  /**
   * After Run: writes what `xpose register --out-dir DIRECTORY` writes (result.json, and per view
   * the final DRR, mask and entropy map); false, with GetLastError, when it cannot.
   */
  bool WriteResultFolder(const std::string& directory);

protected:
  vtkXPRegistrationSession();
  ~vtkXPRegistrationSession() override;

private:
  vtkXPRegistrationSession(const vtkXPRegistrationSession&) = delete;
  void operator=(const vtkXPRegistrationSession&) = delete;

  std::string CTPath, Series, VoxelSize, GeometryPath, Size, IsocenterInCT;
  std::vector<std::string> XRayPaths, ROIPaths;
  double MuWater;
  bool RemoveTable = false;
  bool ChooseTable = true;
  double InitialPose[6] = { 0, 0, 0, 0, 0, 0 };
  std::string Optimizer; ///< xp::DefaultOptimizers() until set
  bool EntropyMask = true;
  std::string Device = "cpu";
  std::string Schedule = "economy";
  std::string CouchMotions, CouchRotationLimit, Target;
  double ActionLevel[2] = { 0.0, 0.0 };
  double MaxUncorrected[2] = { std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity() };
  std::unique_ptr<xp::RegistrationSession> Session;
  std::string LastError;
};

#endif
