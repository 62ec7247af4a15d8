/**
 * @class   vtkHDTWriter
 * @brief   saves the HDT behind a vtkHDTVoxelizer's or vtkHDTReader's output as an .hdt file
 *
 * An .hdt file (format: docs/hdt-format.md) stores the HDT volume itself (tree,
 * leaf grids, grid placement, build statistics), not the hyper tree grid made
 * from it. The writer finds the volume through the handle that vtkHDTVoxelizer
 * and vtkHDTReader put in their output's field data (vtkHDTVolumeHandle.h), so
 * it works with SetInputConnection, SetInputData and pass-through filters
 * alike. MaxDepth and MaskOutside are display options and do not change what
 * is written: the file always holds the whole volume, and reading it back with
 * the same MaxDepth and MaskOutside gives the same hyper tree grid.
 *
 * Any other input (a hyper tree grid from another source, one whose volume is
 * gone, or one moved by a filter) is refused with an error that says so;
 * nothing is written. Failures set the error code and leave no file behind.
 *
 * @sa vtkHDTReader vtkHDTVoxelizer
 */
#ifndef vtkHDTWriter_h
#define vtkHDTWriter_h

#include "HDTReadersModule.h" // export macro
#include "vtkWriter.h"

class vtkHyperTreeGrid;

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
   * zstd level, 1 (fastest) to 19 (smallest). Default 1, as hdt::WriteOptions and hdt-voxelize:
   * on leaf grids it gives files about as small as 3, sooner.
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
  // Across MPI ranks: asks the input for this rank's piece (vtkWriter::Write
  // would ask every rank for the whole data, piece 0 of 1).
  vtkTypeBool ProcessRequest(vtkInformation* request, vtkInformationVector** inInfo,
    vtkInformationVector* outInfo) override;

  char* FileName = nullptr;
  vtkTypeBool CompressLeaves = true;
  int CompressionLevel = 1;

private:
  vtkHDTWriter(const vtkHDTWriter&) = delete;
  void operator=(const vtkHDTWriter&) = delete;
};

#endif
