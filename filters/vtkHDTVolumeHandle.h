// The HDT volume behind a hyper tree grid, found from the grid itself.
//
// The HDT Voxelizer and the HDT Reader convert an hdt::Volume into a
// vtkHyperTreeGrid and keep the volume. Consumers that need the volume (the
// .hdt writer, HDT To Image) find it through a one-value field array,
// "HDTVolumeId", that the producer adds to its output: field data travel with
// shallow copies, pass-through filters (ParaView's vtkPVPostFilter) and
// SetInputData, so no pipeline walk or downcast to a producer class is needed.
// The id names an entry of a process-wide registry of weak references: the
// volume lives as long as its producer keeps it, and an id whose volume is
// gone (the producer re-ran or was deleted) resolves to nothing. Ids carry a
// per-process random salt, so an id read back from a saved .htg file does not
// resolve to an unrelated volume.
//
// A filter that keeps the field data but moves the grid (for example an axis
// reflection) would carry the id of a volume that is no longer what the grid
// shows; Find therefore also checks that the grid's coordinates are still the
// volume's placement.
#pragma once

#include "HDTFiltersModule.h" // export macro

#include <memory>
#include <string>

class vtkDataObject;
class vtkHyperTreeGrid;
namespace hdt
{
struct Volume;
}

class HDTFILTERS_EXPORT vtkHDTVolumeHandle
{
public:
  static const char* ArrayName() { return "HDTVolumeId"; }

  // Registers `volume` (kept by weak reference) and adds the field array that
  // names it to `data` (replacing an older one).
  static void Attach(const std::shared_ptr<const hdt::Volume>& volume, vtkDataObject* data);

  // The volume `grid` was made from, or null with `why` saying what is missing.
  static std::shared_ptr<const hdt::Volume> Find(vtkHyperTreeGrid* grid, std::string& why);
};
