/**
 * @class   vtkHDTVoxelizer
 * @brief   voxelizes a triangle mesh into an HDT and outputs it as a vtkHyperTreeGrid
 *
 * Input: vtkPolyData, or a composite dataset whose vtkPolyData leaves are
 * voxelized together as one mesh. Polygons and triangle strips are
 * triangulated; vertices and lines have no area and are ignored (one warning).
 *
 * The HDT (hybrid dynamic tree, Hossain et al., IA^3 2015) has an effective
 * resolution N = RootGridSize * 2^h * LeafGridSize voxels along the longest side
 * of the mesh: a root grid of R^3 cells, an octree of height h under each, and
 * L^3 leaf grids of 2-bit voxel states where the surface passes. The grid is a
 * cube of N^3 voxels centred on the mesh with one voxel of margin on each side.
 *
 * Output: a vtkHyperTreeGrid with one tree per root cell, the octree levels, and
 * then log2(L) levels refined inside each leaf grid only where surface voxels
 * are. Cell data "VoxelState": 0 outside, 1 inside, 2 surface (see
 * vtkHDTHyperTreeGridConversion.h for coarse and MaxDepth-cut cells). Field
 * data: the build statistics (the paper's Table 1) and phase times.
 *
 * Output port 1: the voxel surface (vtkPolyData), the outer faces of the
 * voxelized solid extracted straight from the HDT (hdt/voxel_surface.hpp):
 * merged quads with cell data "VoxelState" (the state of the voxel behind
 * the face), at the level of detail MaxDepth (a cut cell counts as solid when
 * any voxel below it is). It is what ParaView shows after Apply; the hyper
 * tree grid (port 0) stays there for the hyper tree grid filters.
 *
 * Changing only MaxDepth or MaskOutside re-runs the conversion, not the
 * voxelization: the last volume is kept (GetVolume()) while the input and the
 * build properties are unchanged.
 *
 * The algorithm itself lives in the VTK-free `hdt` library; this class only
 * moves data in and out and reports errors (vtkErrorMacro, empty output).
 */
#ifndef vtkHDTVoxelizer_h
#define vtkHDTVoxelizer_h

#include "HDTFiltersModule.h" // export macro
#include "vtkAlgorithm.h"

#ifndef __VTK_WRAP__
#include <memory> // for std::shared_ptr
#endif

class vtkDataArraySelection;
class vtkHyperTreeGrid;
class vtkPolyData;
#ifndef __VTK_WRAP__
namespace hdt
{
struct Volume;
}
#endif

class HDTFILTERS_EXPORT vtkHDTVoxelizer : public vtkAlgorithm
{
public:
  static vtkHDTVoxelizer* New();
  vtkTypeMacro(vtkHDTVoxelizer, vtkAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum BackendType
  {
    BACKEND_AUTO = 0,
    BACKEND_CPU = 1,
    BACKEND_CUDA = 2
  };

  ///@{
  /**
   * Effective resolution N: voxels along the longest side of the mesh. Must be
   * RootGridSize * 2^h * LeafGridSize for some h >= 0, and at most 65536; an
   * invalid value is an error that names the nearest valid ones. Default 256.
   */
  vtkSetMacro(Resolution, int);
  vtkGetMacro(Resolution, int);
  ///@}

  ///@{
  /**
   * R: root grid cells per axis (one vtkHyperTree each). Default 16.
   */
  vtkSetMacro(RootGridSize, int);
  vtkGetMacro(RootGridSize, int);
  ///@}

  ///@{
  /**
   * L: leaf grid edge in voxels, 8, 16 or 32. Default 16, the paper's and
   * hdt-voxelize's (with R = 16 and N = 256: 16^3 leaf grids right under the
   * root grid, octree height 0).
   */
  vtkSetMacro(LeafGridSize, int);
  vtkGetMacro(LeafGridSize, int);
  ///@}

  ///@{
  /**
   * BACKEND_AUTO (default): the CUDA driver when this build has it and a device
   * is usable, the CPU driver otherwise, and the CPU driver again (with a
   * warning) if the device fails. BACKEND_CPU, BACKEND_CUDA: that driver only;
   * CUDA without a usable device is an error.
   */
  vtkSetClampMacro(Backend, int, BACKEND_AUTO, BACKEND_CUDA);
  vtkGetMacro(Backend, int);
  ///@}

  ///@{
  /**
   * How inside voxels are told from outside ones (hdt::InsideTest):
   * INSIDE_TEST_AUTO (default, as hdt::BuildConfig): exact ray parity for closed
   * meshes, the generalized winding number (inside where w >= 1/2) for open ones;
   * INSIDE_TEST_PARITY: ray parity always (open meshes: the majority of the
   * +x, +y, +z parities, a heuristic; a warning says so);
   * INSIDE_TEST_WINDING: the winding number always. The field arrays
   * InsideTest and InsideTestReason say which ran and why.
   */
  enum InsideTestChoice
  {
    INSIDE_TEST_AUTO = 0,
    INSIDE_TEST_PARITY = 1,
    INSIDE_TEST_WINDING = 2
  };
  vtkSetClampMacro(InsideTest, int, INSIDE_TEST_AUTO, INSIDE_TEST_WINDING);
  vtkGetMacro(InsideTest, int);
  ///@}

  ///@{
  /**
   * Only mark the voxels the surface passes through; no inside/outside
   * classification (faster, and the only meaningful mode for open meshes).
   */
  vtkSetMacro(SurfaceOnly, vtkTypeBool);
  vtkGetMacro(SurfaceOnly, vtkTypeBool);
  vtkBooleanMacro(SurfaceOnly, vtkTypeBool);
  ///@}

  ///@{
  /**
   * -2 (default, AUTO_DEPTH): the deepest depth with at most 1024 cells per
   * axis (full depth up to Resolution 1024), which keeps the first picture to
   * a few million polygons. -1: full depth (h + log2 L, single voxels).
   * k >= 0: cut the trees at depth k; cut cells take the aggregated state of
   * their voxels. Values beyond the full depth mean full depth. The depth used
   * is the field array DisplayDepth (FullDepth beside it).
   */
  vtkSetMacro(MaxDepth, int);
  vtkGetMacro(MaxDepth, int);
  ///@}

  ///@{
  /**
   * Hide (mask) outside leaf cells, so that a surface representation of the
   * hyper tree grid shows the voxelized solid. Default off: ParaView recomputes
   * a masked grid's "pure mask" at every copy through the pipeline (up to 5x
   * the update time, bench/results/pvui.md), and the HTG Contour gives no
   * cells with it.
   */
  vtkSetMacro(MaskOutside, vtkTypeBool);
  vtkGetMacro(MaskOutside, vtkTypeBool);
  vtkBooleanMacro(MaskOutside, vtkTypeBool);
  ///@}

  ///@{
  /**
   * Part labels (hdt/labels.hpp): LABEL_NONE (default); LABEL_BLOCK, one label
   * per block of a multiblock input (its flat index, named after the block);
   * LABEL_CELL_ARRAY, the values (1..65535) of the integer cell array
   * LabelArrayName. The output gains the cell array "Label" and per-label
   * field data (vtkHDTLabelArrays.h).
   */
  enum LabelModes
  {
    LABEL_NONE = 0,
    LABEL_BLOCK = 1,
    LABEL_CELL_ARRAY = 2
  };
  vtkSetClampMacro(LabelBy, int, LABEL_NONE, LABEL_CELL_ARRAY);
  vtkGetMacro(LabelBy, int);
  vtkSetStringMacro(LabelArrayName);
  vtkGetStringMacro(LabelArrayName);
  ///@}

  ///@{
  /**
   * Where several parts claim a voxel: OVERLAP_LOWEST (default) or
   * OVERLAP_HIGHEST label, or, when LabelPriority is a non-empty list of
   * labels ("3,1,2"), the first listed (unlisted labels after, lowest first).
   */
  enum OverlapPolicies
  {
    OVERLAP_LOWEST = 0,
    OVERLAP_HIGHEST = 1
  };
  vtkSetClampMacro(OverlapPolicy, int, OVERLAP_LOWEST, OVERLAP_HIGHEST);
  vtkGetMacro(OverlapPolicy, int);
  vtkSetStringMacro(LabelPriority);
  vtkGetStringMacro(LabelPriority);
  ///@}

  ///@{
  /**
   * Arrays To Transfer (hdt/transfer.hpp): the input's point and cell arrays
   * enabled in these selections are carried onto the surface voxels (cell
   * data of the triangle nearest the voxel centre among those that touch it,
   * of the voxel's label when labelled; point data interpolated at that
   * triangle's closest point), as float32 cell arrays of the same names on
   * the hyper tree grid and the voxel surface (vtkHDTVoxelArrays.h): NaN on
   * inside and outside voxels, coarse cells the NaN-aware mean of their
   * children. None by default.
   */
  vtkDataArraySelection* GetPointDataArraySelection();
  vtkDataArraySelection* GetCellDataArraySelection();
  ///@}

  ///@{
  /**
   * CPU threads for the build and the conversion; 0 (default) = all cores.
   */
  vtkSetClampMacro(Threads, int, 0, 4096);
  vtkGetMacro(Threads, int);
  ///@}

  ///@{
  /**
   * Wall-clock milliseconds of the last run's voxelization (0 when the kept
   * volume was reused), of its conversion to the hyper tree grid and of the
   * voxel surface extraction.
   */
  vtkGetMacro(LastVoxelizationTime, double);
  vtkGetMacro(LastConversionTime, double);
  vtkGetMacro(LastSurfaceTime, double);
  ///@}

  /**
   * True when the last run reused the kept volume (only MaxDepth or
   * MaskOutside had changed).
   */
  vtkGetMacro(LastRunReusedVolume, bool);

  vtkHyperTreeGrid* GetOutput();
  vtkHyperTreeGrid* GetOutput(int port);

  /**
   * The voxel surface (output port 1).
   */
  vtkPolyData* GetSurfaceOutput();

  /**
   * Convenience for pipelines without an upstream algorithm: a vtkPolyData or
   * a composite dataset (SetInputConnection works as for any algorithm).
   */
  void SetInputData(vtkDataObject* input) { this->SetInputDataObject(0, input); }

#ifndef __VTK_WRAP__
  /**
   * The HDT of the last successful run (for writers); null after an error.
   */
  std::shared_ptr<const hdt::Volume> GetVolume() const;
#endif

  vtkTypeBool ProcessRequest(vtkInformation* request, vtkInformationVector** inInfo,
    vtkInformationVector* outInfo) override;

protected:
  vtkHDTVoxelizer();
  ~vtkHDTVoxelizer() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  virtual int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector);

  int Resolution = 256;
  int RootGridSize = 16;
  int LeafGridSize = 16;
  int Backend = BACKEND_AUTO;
  vtkTypeBool SurfaceOnly = false;
  int InsideTest = INSIDE_TEST_AUTO;
  int MaxDepth = -2;
  vtkTypeBool MaskOutside = false;
  int Threads = 0;
  int LabelBy = LABEL_NONE;
  char* LabelArrayName = nullptr;
  int OverlapPolicy = OVERLAP_LOWEST;
  char* LabelPriority = nullptr;
  double LastVoxelizationTime = 0;
  double LastConversionTime = 0;
  double LastSurfaceTime = 0;
  bool LastRunReusedVolume = false;

private:
  vtkHDTVoxelizer(const vtkHDTVoxelizer&) = delete;
  void operator=(const vtkHDTVoxelizer&) = delete;

  void Fail(vtkHyperTreeGrid* output, const char* message);
  void FillSurface(const hdt::Volume& volume, vtkInformationVector* outputVector);

  struct Internals;
  Internals* Internal;
};

#endif
