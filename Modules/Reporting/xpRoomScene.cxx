#include "xpRoomScene.h"

#include "xpCanvas.h"
#include "xpImageGeometry.h"

#include <vtkActor.h>
#include <vtkAutoInit.h>
#include <vtkCamera.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageShrink3D.h>
#include <vtkLineSource.h>
#include <vtkMatrix4x4.h>
#include <vtkPlaneSource.h>
#include <vtkPoints.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>
#include <vtkWindowToImageFilter.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

VTK_MODULE_INIT(vtkRenderingOpenGL2);

namespace xp
{

namespace
{

// Colours per imager (RGB 0..1), then more if a geometry has more imagers.
const double ViewColours[4][3] = { { 1.0, 0.55, 0.1 }, { 0.2, 0.75, 1.0 }, { 0.6, 0.9, 0.3 }, { 0.9, 0.4, 0.8 } };
const double BoneColour[3] = { 0.95, 0.87, 0.70 };

vtkSmartPointer<vtkActor> MakeActor(vtkAlgorithmOutput* source, const double rgb[3], double opacity = 1.0)
{
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputConnection(source);
  mapper->ScalarVisibilityOff();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(rgb[0], rgb[1], rgb[2]);
  actor->GetProperty()->SetOpacity(opacity);
  return actor;
}

vtkSmartPointer<vtkActor> Line(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const double rgb[3], double width)
{
  auto line = vtkSmartPointer<vtkLineSource>::New();
  line->SetPoint1(from.data());
  line->SetPoint2(to.data());
  vtkSmartPointer<vtkActor> actor = MakeActor(line->GetOutputPort(), rgb);
  actor->GetProperty()->SetLineWidth(static_cast<float>(width));
  actor->GetProperty()->LightingOff();
  return actor;
}

vtkSmartPointer<vtkActor> Sphere(const Eigen::Vector3d& centre, double radius, const double rgb[3])
{
  auto sphere = vtkSmartPointer<vtkSphereSource>::New();
  sphere->SetCenter(centre.data());
  sphere->SetRadius(radius);
  sphere->SetThetaResolution(24);
  sphere->SetPhiResolution(16);
  return MakeActor(sphere->GetOutputPort(), rgb);
}

vtkSmartPointer<vtkMatrix4x4> ToVTK(const Eigen::Isometry3d& transform)
{
  auto matrix = vtkSmartPointer<vtkMatrix4x4>::New();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      matrix->SetElement(r, c, transform.matrix()(r, c));
  return matrix;
}

} // namespace

RoomScene::RoomScene(const StereoGeometry& geometry)
  : Geometry(geometry)
{
}

void RoomScene::SetCT(vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom, double boneHU)
{
  // Work in index units (the stock filters ignore the direction matrix), then place the points.
  auto indexImage = vtkSmartPointer<vtkImageData>::New();
  indexImage->ShallowCopy(ct);
  int dims[3];
  ct->GetDimensions(dims);
  indexImage->SetOrigin(0, 0, 0);
  indexImage->SetSpacing(1, 1, 1);
  indexImage->SetExtent(0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1);
  const double* spacing = ct->GetSpacing();
  const double voxel = std::max({ spacing[0] * dims[0], spacing[1] * dims[1], spacing[2] * dims[2] }) / 128.0;
  auto shrink = vtkSmartPointer<vtkImageShrink3D>::New();
  shrink->SetInputData(indexImage);
  shrink->SetShrinkFactors(std::max(1, static_cast<int>(voxel / spacing[0])), std::max(1, static_cast<int>(voxel / spacing[1])),
    std::max(1, static_cast<int>(voxel / spacing[2])));
  shrink->AveragingOn();
  auto surface = vtkSmartPointer<vtkFlyingEdges3D>::New();
  surface->SetInputConnection(shrink->GetOutputPort());
  surface->SetValue(0, boneHU);
  surface->ComputeNormalsOff();
  surface->ComputeGradientsOff();
  surface->ComputeScalarsOff();
  surface->Update();

  auto placed = vtkSmartPointer<vtkPolyData>::New();
  placed->DeepCopy(surface->GetOutput());
  const Eigen::Affine3d indexToRoom = plannedCTToRoom * IndexToPhysical(ct);
  vtkPoints* points = placed->GetPoints();
  for (vtkIdType i = 0; points && i < points->GetNumberOfPoints(); ++i)
  {
    double p[3];
    points->GetPoint(i, p);
    const Eigen::Vector3d room = indexToRoom * Eigen::Vector3d(p[0], p[1], p[2]);
    points->SetPoint(i, room.data());
  }
  auto normals = vtkSmartPointer<vtkPolyDataNormals>::New();
  normals->SetInputData(placed);
  normals->SplittingOff();
  normals->Update();
  this->Bone = normals->GetOutput();
}

vtkSmartPointer<vtkImageData> RoomScene::Render(int width, int height) const
{
  // Left: the whole room. Right: a close-up of the bone, where a misalignment is visible.
  auto room = vtkSmartPointer<vtkRenderer>::New();
  auto closeUp = vtkSmartPointer<vtkRenderer>::New();
  room->SetViewport(0.0, 0.0, 0.5, 1.0);
  closeUp->SetViewport(0.5, 0.0, 1.0, 1.0);
  room->SetBackground(0.10, 0.12, 0.16);
  closeUp->SetBackground(0.13, 0.15, 0.20);
  const Eigen::Vector3d& iso = this->Geometry.isocenter;
  for (size_t v = 0; v < this->Geometry.views.size(); ++v)
  {
    const XRayView& view = this->Geometry.views[v];
    const double* colour = ViewColours[v % 4];
    const double c = view.Columns() - 0.5, r = view.Rows() - 0.5;
    Eigen::Vector3d corners[4] = { view.PixelCenter(-0.5, -0.5), view.PixelCenter(c, -0.5), view.PixelCenter(c, r),
      view.PixelCenter(-0.5, r) };
    auto panel = vtkSmartPointer<vtkPlaneSource>::New();
    panel->SetOrigin(corners[0].data());
    panel->SetPoint1(corners[1].data());
    panel->SetPoint2(corners[3].data());
    room->AddActor(MakeActor(panel->GetOutputPort(), colour, 0.55));
    room->AddActor(Sphere(view.source, 30.0, colour));
    const Eigen::Vector3d centre = view.PixelCenter((view.Columns() - 1) / 2.0, (view.Rows() - 1) / 2.0);
    room->AddActor(Line(view.source, centre, colour, 3.0));
    closeUp->AddActor(Line(view.source, centre, colour, 3.0));
    for (const Eigen::Vector3d& corner : corners)
      room->AddActor(Line(view.source, corner, colour, 1.0));
  }
  const double red[3] = { 0.9, 0.2, 0.2 }, green[3] = { 0.3, 0.85, 0.3 }, blue[3] = { 0.35, 0.5, 1.0 };
  for (vtkRenderer* renderer : { room.GetPointer(), closeUp.GetPointer() })
  {
    renderer->AddActor(Sphere(iso, 4.0, red));
    renderer->AddActor(Line(iso, iso + Eigen::Vector3d(150, 0, 0), red, 3.0));
    renderer->AddActor(Line(iso, iso + Eigen::Vector3d(0, 150, 0), green, 3.0));
    renderer->AddActor(Line(iso, iso + Eigen::Vector3d(0, 0, 150), blue, 3.0));
  }
  double boneBounds[6] = { iso[0] - 100, iso[0] + 100, iso[1] - 100, iso[1] + 100, iso[2] - 100, iso[2] + 100 };
  if (this->Bone && this->Bone->GetNumberOfPoints() > 0)
  {
    this->Bone->GetBounds(boneBounds);
    const double planned[3] = { 0.75, 0.75, 0.78 };
    auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
    mapper->SetInputData(this->Bone);
    mapper->ScalarVisibilityOff();
    for (vtkRenderer* renderer : { room.GetPointer(), closeUp.GetPointer() })
    {
      auto plannedActor = vtkSmartPointer<vtkActor>::New();
      plannedActor->SetMapper(mapper);
      plannedActor->GetProperty()->SetColor(planned[0], planned[1], planned[2]);
      plannedActor->GetProperty()->SetOpacity(0.3);
      auto estimated = vtkSmartPointer<vtkActor>::New();
      estimated->SetMapper(mapper);
      estimated->GetProperty()->SetColor(BoneColour[0], BoneColour[1], BoneColour[2]);
      estimated->SetUserMatrix(ToVTK(this->Misalignment.ToTransform(iso)));
      renderer->AddActor(estimated);
      renderer->AddActor(plannedActor);
    }
  }

  // Look at the isocentre across the plane of the two central rays, from above the couch.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  if (this->Geometry.views.size() >= 2)
  {
    normal = (this->Geometry.views[0].source - iso).cross(this->Geometry.views[1].source - iso);
    normal = normal.norm() > 0 ? normal.normalized() : Eigen::Vector3d::UnitZ();
  }
  const Eigen::Vector3d position = iso + 1000.0 * (normal + 0.5 * Eigen::Vector3d::UnitZ() + 0.4 * Eigen::Vector3d::UnitX());
  for (vtkRenderer* renderer : { room.GetPointer(), closeUp.GetPointer() })
  {
    vtkCamera* camera = renderer->GetActiveCamera();
    camera->SetFocalPoint(iso.data());
    camera->SetPosition(position.data());
    camera->SetViewUp(0, 0, 1);
  }
  room->ResetCamera();
  room->GetActiveCamera()->Zoom(1.15);
  room->ResetCameraClippingRange();
  closeUp->ResetCamera(boneBounds);
  closeUp->GetActiveCamera()->Zoom(1.2);
  closeUp->ResetCameraClippingRange();

  auto window = vtkSmartPointer<vtkRenderWindow>::New();
  window->SetOffScreenRendering(1);
  window->SetSize(width, height);
  window->SetMultiSamples(4);
  window->AddRenderer(room);
  window->AddRenderer(closeUp);
  window->Render();
  auto grab = vtkSmartPointer<vtkWindowToImageFilter>::New();
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();

  // The legend, drawn in 2D so that it needs no font rendering in OpenGL.
  cv::Mat picture = canvas::FromVTK(grab->GetOutput());
  int y = 22;
  const auto legend = [&](const double rgb[3], const std::string& text) {
    const cv::Scalar colour(255 * rgb[2], 255 * rgb[1], 255 * rgb[0]);
    cv::rectangle(picture, cv::Rect(10, y - 11, 14, 12), colour, cv::FILLED);
    canvas::Text(picture, text, cv::Point(30, y), 0.8, cv::Scalar(235, 235, 235));
    y += 20;
  };
  for (size_t v = 0; v < this->Geometry.views.size(); ++v)
    legend(ViewColours[v % 4], "imager " + this->Geometry.views[v].name + ": source, panel, central ray");
  const double planned[3] = { 0.75, 0.75, 0.78 };
  legend(planned, "bone at the planned pose (translucent)");
  legend(BoneColour, "bone at the estimated pose: " + this->Misalignment.ToString());
  legend(red, "isocentre; room axes X red, Y green, Z blue; right: close-up");
  return canvas::ToVTK(picture);
}

} // namespace xp
