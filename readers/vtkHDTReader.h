/**
 * @class   vtkHDTReader
 * @brief   reads an .hdt file (an HDT sparse volume) as a vtkHyperTreeGrid and its voxel surface
 *
 * The file (format: docs/hdt-format.md) is read and fully validated by
 * hdt::readHdt, then converted by the same code as vtkHDTVoxelizer's output
 * (vtkHDTToHyperTreeGrid), so reading a file written from the voxelizer gives
 * the voxelizer's hyper tree grid: cell data "VoxelState" (0 outside, 1 inside,
 * 2 surface) and the build statistics as field data.
 *
 * Output port 1: the voxel surface (vtkPolyData), as vtkHDTVoxelizer's port 1.
 * The reader is a plain vtkAlgorithm source with two outputs of different
 * types (a vtkHyperTreeGridAlgorithm is a one-output HTG filter).
 *
 * MaxDepth and MaskOutside only change the conversion: changing them re-uses
 * the volume read last, as long as FileName and the file's size and time stamp
 * are unchanged.
 *
 * A file that cannot be opened, is not an .hdt file, is truncated or corrupt
 * gives one vtkErrorMacro naming the file and the problem, and an empty output.
 *
 * @sa vtkHDTWriter vtkHDTVoxelizer
 */
#ifndef vtkHDTReader_h
#define vtkHDTReader_h

#include "HDTReadersModule.h" // export macro
#include "vtkAlgorithm.h"

#ifndef __VTK_WRAP__
#include <memory> // for std::shared_ptr
#endif

class vtkHyperTreeGrid;
class vtkPolyData;

#ifndef __VTK_WRAP__
namespace hdt
{
struct Volume;
}
#endif

class HDTREADERS_EXPORT vtkHDTReader : public vtkAlgorithm
{
public:
  static vtkHDTReader* New();
  vtkTypeMacro(vtkHDTReader, vtkAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The .hdt file to read.
   */
  vtkSetFilePathMacro(FileName);
  vtkGetFilePathMacro(FileName);
  ///@}

  ///@{
  /**
   * -2 (default): automatic, as vtkHDTVoxelizer's (at most 1024 cells per
   * axis). -1: full depth, single voxels. k >= 0: cut every tree at depth
   * k (0 = the root grid alone) for a quick coarse view; a cut cell is 2 if any
   * voxel below it is on the surface, else 1 if most of its voxels are inside,
   * else 0. Values past the full depth mean full depth.
   */
  vtkSetClampMacro(MaxDepth, int, -2, VTK_INT_MAX);
  vtkGetMacro(MaxDepth, int);
  ///@}

  ///@{
  /**
   * Hide (mask) the outside leaf cells, so that a surface representation shows
   * the voxelized solid. Default off, as in vtkHDTVoxelizer.
   */
  vtkSetMacro(MaskOutside, vtkTypeBool);
  vtkGetMacro(MaskOutside, vtkTypeBool);
  vtkBooleanMacro(MaskOutside, vtkTypeBool);
  ///@}

  /**
   * 1 when the file starts with the .hdt magic ("HDT\0"), else 0. Cheap: reads
   * 4 bytes; the full validation happens when the data is read.
   */
  virtual int CanReadFile(VTK_FILEPATH const char* fileName);

  ///@{
  /**
   * The hyper tree grid (port 0) and the voxel surface (port 1).
   */
  vtkHyperTreeGrid* GetOutput();
  vtkPolyData* GetSurfaceOutput();
  ///@}

  vtkTypeBool ProcessRequest(vtkInformation* request, vtkInformationVector** inInfo,
    vtkInformationVector* outInfo) override;

#ifndef __VTK_WRAP__
  /**
   * The volume of the last successful read; null before it and after an
   * error. vtkHDTWriter saves it as it is.
   */
  std::shared_ptr<const hdt::Volume> GetVolume() const;
#endif

protected:
  vtkHDTReader();
  ~vtkHDTReader() override;

  virtual int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*);
  int FillOutputPortInformation(int port, vtkInformation* info) override;

  char* FileName = nullptr;
  int MaxDepth = -2;
  vtkTypeBool MaskOutside = false;

private:
  vtkHDTReader(const vtkHDTReader&) = delete;
  void operator=(const vtkHDTReader&) = delete;

  struct Internals;
  Internals* Internal;
};

#endif
