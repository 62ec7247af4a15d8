// Display defaults the plugin installs when ParaView loads it (GUI, pvpython,
// pvbatch alike): the colour map of any array named "VoxelState" is
// categorical, with the three states as named annotations and fixed colours.
//
// Mechanism: ParaView's vtkSMTransferFunctionManager, when it creates the
// lookup table of an array, applies the settings found under
// ".array_lookup_tables.<array name>.PVLookupTable.<property>" to it
// (vtkSMSettings::GetProxySettings). ParaView itself
// registers its built-in defaults the same way, as a settings collection of
// priority 0.0, below the user's and site's settings: a user who saves another
// colour map for VoxelState as default keeps it. No representation hint is
// needed, and the surface and image outputs (also "VoxelState") share it.
#include "vtkSMSettings.h"

namespace
{
// Outside light grey, inside orange, surface blue: the colours of
// scripts/render_demo.py (blue/orange stay distinct for colour-blind readers).
const char* const kVoxelStateSettings = R"json({
  "array_lookup_tables": {
    "VoxelState": {
      "PVLookupTable": {
        "IndexedLookup": 1,
        "Annotations": ["0", "Outside", "1", "Inside", "2", "Surface"],
        "IndexedColors": [0.75, 0.75, 0.75, 0.97, 0.60, 0.20, 0.40, 0.62, 0.85],
        "IndexedOpacities": [1.0, 1.0, 1.0]
      }
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
