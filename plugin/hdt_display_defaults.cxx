// Display defaults the plugin installs when ParaView loads it (GUI, pvpython,
// pvbatch alike): the colour map of any array named "VoxelState" is
// categorical, with the three states as named annotations and fixed colours.
//
// Mechanism: ParaView's vtkSMTransferFunctionManager, when it creates the
// lookup table of an array, applies the settings found under
// ".array_lookup_tables.<array name>" to it (vtkSMSettings). ParaView itself
// registers its built-in defaults the same way, as a settings collection of
// priority 0.0, below the user's and site's settings: a user who saves another
// colour map for VoxelState as default keeps it. No representation hint is
// needed, and the surface and image outputs (also "VoxelState") share it.
#include "vtkSMSettings.h"

namespace
{
// Outside light grey, inside blue, surface orange (readable on ParaView's
// grey-blue background, distinct for colour-blind readers).
const char* const kVoxelStateSettings = R"json({
  "array_lookup_tables": {
    "VoxelState": {
      "IndexedLookup": 1,
      "Annotations": ["0", "Outside", "1", "Inside", "2", "Surface"],
      "IndexedColors": [0.75, 0.75, 0.75, 0.23, 0.47, 0.85, 0.96, 0.58, 0.12],
      "IndexedOpacities": [1.0, 1.0, 1.0]
    }
  }
})json";

struct InstallDisplayDefaults
{
  InstallDisplayDefaults()
  {
    vtkSMSettings::GetInstance()->AddCollectionFromString(kVoxelStateSettings, 0.0);
  }
};
// Runs when the plugin library is loaded.
const InstallDisplayDefaults installDisplayDefaults;
} // namespace
