"""xpose: 6-DOF patient pose from stereo X-rays and the planning CT, as VTK filters.

The filters are VTK algorithms: connect them to VTK's own readers, writers and numpy
(vtkmodules.util.numpy_support). The value types the filters need have a Python face on the
filters themselves: a geometry read from its JSON file, a pose as six numbers (tx, ty, tz in mm;
pitch, roll, yaw in degrees; Coordinates.md), and the registration's result as the JSON record that
`xpose register` writes to result.json.

vtkXPRegistrationSession runs what `xpose register` runs, from the same files: the same inputs
give the same pose and verdict as the command.
"""
# Debian's VTK modules that hold the filters' base classes, loaded before the filters.
import vtkmodules.vtkCommonCore  # noqa: F401
import vtkmodules.vtkCommonDataModel  # noqa: F401
import vtkmodules.vtkCommonExecutionModel  # noqa: F401

from .vtkXPDICOM import vtkXPDICOMCTReader  # noqa: F401
from .vtkXPDRR import vtkXPDRRFilter  # noqa: F401
from .vtkXPMasking import vtkXPEntropyMaskFilter  # noqa: F401
from .vtkXPMetrics import vtkXPMutualInformationMetric  # noqa: F401
from .vtkXPRegistration import vtkXPStereoRegistrationFilter  # noqa: F401
from .vtkXPReporting import vtkXPOverlayFilter  # noqa: F401
from .vtkXPSession import vtkXPRegistrationSession  # noqa: F401

__all__ = [
    "vtkXPDICOMCTReader",
    "vtkXPDRRFilter",
    "vtkXPEntropyMaskFilter",
    "vtkXPMutualInformationMetric",
    "vtkXPStereoRegistrationFilter",
    "vtkXPOverlayFilter",
    "vtkXPRegistrationSession",
]
