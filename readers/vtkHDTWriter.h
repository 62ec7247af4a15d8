/**
 * @class   vtkHDTWriter
 * @brief   saves the HDT behind a vtkHDTVoxelizer's or vtkHDTReader's output as an .hdt file
 *
 * An .hdt file (format: docs/hdt-format.md) stores the HDT volume itself (tree,
 * leaf grids, grid placement, build statistics), not the hyper tree grid made
 * from it. The writer therefore takes the volume from the algorithm that
 * produced its input: a vtkHDTVoxelizer or a vtkHDTReader connected directly
 * (SetInputConnection). Their MaxDepth and MaskOutside are display options and
 * do not change what is written: the file always holds the whole volume, and
 * reading it back with the same MaxDepth and MaskOutside gives the same hyper
 * tree grid.
 *
 * Any other input (a hyper tree grid from another source, one that went
 * through other filters, or one handed over with SetInputData) is refused with
 * an error that says so; nothing is written. Failures set the error code and
 * leave no file behind.
 *
 * @sa vtkHDTReader vtkHDTVoxelizer
 */
#ifndef vtkHDTWriter_h
#define vtkHDTWriter_h

#include "HDTReadersModule.h" // export macro
#include "vtkWriter.h"

#ifndef __VTK_WRAP__
#include <memory> // for std::shared_ptr
#include <string> // for std::string
#endif

class vtkHyperTreeGrid;
#ifndef __VTK_WRAP__
namespace hdt
{
struct Volume;
}
#endif

class HDTREADERS_EXPORT vtkHDTWriter : public vtkWriter
{
public:
  static vtkHDTWriter* New();
  vtkTypeMacro(vtkHDTWriter, vtkWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The .hdt file to write.
   */
  vtkSetFilePathMacro(FileName);
  vtkGetFilePathMacro(FileName);
  ///@}

  ///@{
  /**
   * Compress the leaf grids (the bulk of the file) with zstd. Default on;
   * ignored (raw leaves) when the plugin was built without zstd.
   */
  vtkSetMacro(CompressLeaves, vtkTypeBool);
  vtkGetMacro(CompressLeaves, vtkTypeBool);
  vtkBooleanMacro(CompressLeaves, vtkTypeBool);
  ///@}

  ///@{
  /**
   * zstd level, 1 (fastest) to 19 (smallest). Default 3.
   */
  vtkSetClampMacro(CompressionLevel, int, 1, 19);
  vtkGetMacro(CompressionLevel, int);
  ///@}

  vtkHyperTreeGrid* GetInput();

protected:
  vtkHDTWriter();
  ~vtkHDTWriter() override;

  void WriteData() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;

  char* FileName = nullptr;
  vtkTypeBool CompressLeaves = true;
  int CompressionLevel = 3;

private:
  vtkHDTWriter(const vtkHDTWriter&) = delete;
  void operator=(const vtkHDTWriter&) = delete;

#ifndef __VTK_WRAP__
  // The volume behind the input, from the vtkHDTVoxelizer or vtkHDTReader that
  // produced it; false with the reason otherwise.
  bool FindVolume(std::shared_ptr<const hdt::Volume>& volume, std::string& why);
#endif
};

#endif
