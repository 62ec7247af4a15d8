/**
 * @class   vtkHDTToImage
 * @brief   voxel states of an HDT over a box, as a vtkImageData (volume rendering, image filters)
 *
 * Input: the vtkHyperTreeGrid of a vtkHDTVoxelizer or vtkHDTReader (or that
 * grid passed on unchanged); the HDT volume behind it is found through its
 * field data (vtkHDTVolumeHandle.h). The whole volume is used, whatever
 * MaxDepth and MaskOutside the grid was made with.
 *
 * Output: one point per block of 2^Level voxels per axis over the region, at
 * the block's centre (spacing 2^Level voxels), point array "VoxelState"
 * (unsigned char: 0 outside, 1 inside, 2 surface). A block takes the state of
 * its voxels by the rule of the hyper tree grid's cut cells: surface if any
 * voxel is surface, else inside if more than half are inside, else outside.
 * Level 0 over the whole grid is the dense export (hdt-voxelize --dense).
 * Arrays transferred from the mesh (hdt/transfer.hpp) come along as float32
 * point arrays: a block's value is the NaN-aware mean of its children's, as
 * on the hyper tree grid (vtkHDTVoxelArrays.h); NaN off the surface.
 *
 * The region is the box [RegionOrigin, RegionOrigin + RegionSize] in world
 * coordinates when UseRegion is on, else the whole grid; it is widened to
 * whole blocks and clipped to the grid. An output larger than MaxMegabytes
 * (one byte a point) is refused with an error naming the level that fits.
 */
#ifndef vtkHDTToImage_h
#define vtkHDTToImage_h

#include "HDTFiltersModule.h" // export macro
#include "vtkImageAlgorithm.h"

class HDTFILTERS_EXPORT vtkHDTToImage : public vtkImageAlgorithm
{
public:
  static vtkHDTToImage* New();
  vtkTypeMacro(vtkHDTToImage, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Coarsening: blocks of 2^Level voxels per axis become one point. Default 0.
   */
  vtkSetClampMacro(Level, int, 0, 16);
  vtkGetMacro(Level, int);
  ///@}

  ///@{
  /**
   * Off (default): the whole grid. On: the box RegionOrigin + [0, RegionSize].
   */
  vtkSetMacro(UseRegion, vtkTypeBool);
  vtkGetMacro(UseRegion, vtkTypeBool);
  vtkBooleanMacro(UseRegion, vtkTypeBool);
  vtkSetVector3Macro(RegionOrigin, double);
  vtkGetVector3Macro(RegionOrigin, double);
  vtkSetVector3Macro(RegionSize, double);
  vtkGetVector3Macro(RegionSize, double);
  ///@}

  ///@{
  /**
   * Largest output accepted, in MiB (one byte a point). Default 1024 (1024^3 points).
   */
  vtkSetClampMacro(MaxMegabytes, double, 0.0, 1.0e9);
  vtkGetMacro(MaxMegabytes, double);
  ///@}

protected:
  vtkHDTToImage();
  ~vtkHDTToImage() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int Level = 0;
  vtkTypeBool UseRegion = false;
  double RegionOrigin[3] = { 0, 0, 0 };
  double RegionSize[3] = { 1, 1, 1 };
  double MaxMegabytes = 1024;

private:
  vtkHDTToImage(const vtkHDTToImage&) = delete;
  void operator=(const vtkHDTToImage&) = delete;

  struct Plan;
  bool MakePlan(vtkInformationVector** inputVector, Plan& plan, bool report);
};

#endif
