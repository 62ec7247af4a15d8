// The CUDA set-up a process does once (context, kernels, memory pool, pinned
// copy-back staging: hdt::prepareCuda; before it oneTBB's worker threads:
// hdt::startHostThreads), started on a background thread when
// the first HDT Voxelizer is made, so that the first Apply builds as fast as
// the tenth instead of paying it (issue 18). A no-op in builds without CUDA,
// on machines without a device, and across MPI ranks (each rank's device is
// chosen at build time there).
#ifndef vtkHDTCudaWarmUp_h
#define vtkHDTCudaWarmUp_h

namespace vtkHDTCudaWarmUp
{
// Starts the set-up once a process; later calls do nothing.
void Start();
// Returns once the set-up (if started) is over: a build calls this before it
// uses the device, so that the two never run at the same time, and a
// voxelizer's destructor, so that it is over before the process can end.
void Wait();
}

#endif
