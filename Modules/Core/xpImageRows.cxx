#include "xpImageRows.h"

#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkStreamingDemandDrivenPipeline.h>

namespace xp
{

void RequestWholeExtents(vtkInformationVector** inputVector, int ports)
{
  for (int port = 0; port < ports; ++port)
  {
    if (vtkInformation* info = inputVector[port]->GetInformationObject(0))
    {
      int whole[6];
      info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
      info->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
    }
  }
}

} // namespace xp
