// Categorical colours for part labels, named after the parts (issue 13): a
// representation coloured by an array named "Label" gets a categorical
// (IndexedLookup) colour map whose annotations are the label values with
// their names, read from the field data the HDT outputs carry (LabelIds and
// LabelNames, vtkHDTLabelArrays.h: block names for Label By Block).
//
// Mechanism: static settings (hdt_display_defaults.cxx) cannot know the
// names, and ParaView 5.11 has no way for data to annotate a colour map (its
// array information keeps only the first 6 non-empty strings of a string
// array). So the plugin watches the server manager, the level the GUI,
// pvpython and pvbatch share: each registered representation is observed,
// and when its colour array is "Label" (chosen, or its lookup table
// replaced) the values not yet annotated on that lookup table are
// added with their names and a colour of a qualitative palette; annotations
// already there (a user's renaming or recolouring) are left as they are.
// The names are read from the data object of the representation's input on
// the client, so in builtin sessions only; with a remote server the colour
// map stays as ParaView makes it. Labels that appear in the data later (a new
// build with more parts) are added the next time Label is chosen.
#include "vtkAlgorithm.h"
#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkFieldData.h"
#include "vtkSMPropertyHelper.h"
#include "vtkSMProxy.h"
#include "vtkSMProxyManager.h"
#include "vtkSMSessionProxyManager.h"
#include "vtkSMSourceProxy.h"
#include "vtkStringArray.h"

#include <cstring>
#include <string>
#include <vector>

namespace
{
const char kLabelArray[] = "Label";

// Tableau 10: distinct hues, none of them the VoxelState colours' exact ones.
const double kPalette[][3] = { { 0.122, 0.467, 0.706 }, { 1.000, 0.498, 0.055 },
  { 0.173, 0.627, 0.173 }, { 0.839, 0.153, 0.157 }, { 0.580, 0.404, 0.741 },
  { 0.549, 0.337, 0.294 }, { 0.890, 0.467, 0.761 }, { 0.498, 0.498, 0.498 },
  { 0.737, 0.741, 0.133 }, { 0.090, 0.745, 0.812 } };
const int kPaletteSize = int(sizeof(kPalette) / sizeof(kPalette[0]));

// The data object shown by `representation`, where the client has it.
vtkDataObject* shownData(vtkSMProxy* representation)
{
  vtkSMPropertyHelper input(representation, "Input", /*quiet=*/true);
  auto* source = vtkSMSourceProxy::SafeDownCast(input.GetAsProxy());
  auto* algorithm = source ? vtkAlgorithm::SafeDownCast(source->GetClientSideObject()) : nullptr;
  const int port = int(input.GetOutputPort());
  return algorithm && port < algorithm->GetNumberOfOutputPorts()
    ? algorithm->GetOutputDataObject(port)
    : nullptr;
}

// Label values and names of the data (LabelIds, LabelNames field data).
std::vector<std::pair<std::string, std::string>> labelTable(vtkDataObject* data)
{
  std::vector<std::pair<std::string, std::string>> table;
  vtkFieldData* fd = data ? data->GetFieldData() : nullptr;
  vtkDataArray* ids = fd ? fd->GetArray("LabelIds") : nullptr;
  auto* names = fd ? vtkStringArray::SafeDownCast(fd->GetAbstractArray("LabelNames")) : nullptr;
  for (vtkIdType i = 0; ids && i < ids->GetNumberOfTuples(); ++i)
  {
    const std::string value = std::to_string(static_cast<long long>(ids->GetTuple1(i)));
    std::string name = names && i < names->GetNumberOfValues() ? names->GetValue(i) : std::string();
    table.emplace_back(value, name.empty() ? "Label " + value : name);
  }
  return table;
}

// True for the colour map ParaView made for "Label" (registered as
// Label.PVLookupTable, or <prefix>_Label.PVLookupTable for a separate one):
// ColorArrayName changes before LookupTable does, and the previous array's
// map must not get the labels.
bool isLabelLookupTable(vtkSMProxy* lut)
{
  if (!lut || !lut->GetProperty("Annotations") || !lut->GetProperty("IndexedColors") ||
    !lut->GetSessionProxyManager())
  {
    return false;
  }
  const char* registered = lut->GetSessionProxyManager()->GetProxyName("lookup_tables", lut);
  const std::string name = registered ? registered : "";
  const std::string own = std::string(kLabelArray) + ".PVLookupTable";
  return name == own ||
    (name.size() > own.size() && name.compare(name.size() - own.size() - 1, std::string::npos, "_" + own) == 0);
}

// Adds the labels of the shown data that `lut` does not annotate yet.
void annotateLabels(vtkSMProxy* representation)
{
  vtkSMPropertyHelper colorArray(representation, "ColorArrayName", /*quiet=*/true);
  const char* arrayName = colorArray.GetInputArrayNameToProcess();
  vtkSMProxy* lut = vtkSMPropertyHelper(representation, "LookupTable", true).GetAsProxy();
  if (!arrayName || std::strcmp(arrayName, kLabelArray) != 0 || !isLabelLookupTable(lut))
  {
    return;
  }
  const auto table = labelTable(shownData(representation));
  if (table.empty())
  {
    return;
  }
  vtkSMPropertyHelper annotations(lut, "Annotations");
  vtkSMPropertyHelper colors(lut, "IndexedColors");
  std::vector<std::string> entries;
  for (unsigned int i = 0; i < annotations.GetNumberOfElements(); ++i)
  {
    entries.emplace_back(annotations.GetAsString(i));
  }
  std::vector<double> rgb = colors.GetDoubleArray();
  rgb.resize(3 * (entries.size() / 2), 1.0); // one colour an annotation
  bool added = false;
  for (const auto& label : table)
  {
    bool known = false;
    for (size_t i = 0; i + 1 < entries.size() && !known; i += 2)
    {
      known = entries[i] == label.first;
    }
    if (known)
    {
      continue;
    }
    const double* colour = kPalette[(std::stoll(label.first) + kPaletteSize - 1) % kPaletteSize];
    entries.push_back(label.first);
    entries.push_back(label.second);
    rgb.insert(rgb.end(), colour, colour + 3);
    added = true;
  }
  const bool indexed = vtkSMPropertyHelper(lut, "IndexedLookup").GetAsInt() != 0;
  if (!added && indexed)
  {
    return;
  }
  annotations.SetNumberOfElements(unsigned(entries.size()));
  for (size_t i = 0; i < entries.size(); ++i)
  {
    annotations.Set(unsigned(i), entries[i].c_str());
  }
  colors.Set(rgb.data(), unsigned(rgb.size()));
  vtkSMPropertyHelper(lut, "IndexedLookup").Set(1);
  lut->UpdateVTKObjects();
}

void onRepresentationEvent(vtkObject* caller, unsigned long, void*, void* callData)
{
  const char* property = static_cast<const char*>(callData);
  if (property &&
    (std::strcmp(property, "ColorArrayName") == 0 || std::strcmp(property, "LookupTable") == 0))
  {
    annotateLabels(vtkSMProxy::SafeDownCast(caller));
  }
}

// A new representation with a colour map gets observed.
void onRegister(vtkObject*, unsigned long, void*, void* callData)
{
  auto* info = static_cast<vtkSMProxyManager::RegisteredProxyInformation*>(callData);
  if (!info || info->Type != vtkSMProxyManager::RegisteredProxyInformation::PROXY || !info->Proxy ||
    !info->GroupName || std::strcmp(info->GroupName, "representations") != 0 ||
    !info->Proxy->GetProperty("ColorArrayName") || !info->Proxy->GetProperty("LookupTable"))
  {
    return;
  }
  static vtkCallbackCommand* const watch = [] {
    vtkCallbackCommand* command = vtkCallbackCommand::New(); // lives as long as the process
    command->SetCallback(onRepresentationEvent);
    return command;
  }();
  info->Proxy->AddObserver(vtkCommand::PropertyModifiedEvent, watch);
}

void watchSession(vtkSMSessionProxyManager* pxm)
{
  static vtkCallbackCommand* const registered = [] {
    vtkCallbackCommand* command = vtkCallbackCommand::New(); // lives as long as the process
    command->SetCallback(onRegister);
    return command;
  }();
  if (pxm && !pxm->HasObserver(vtkCommand::RegisterEvent, registered))
  {
    pxm->AddObserver(vtkCommand::RegisterEvent, registered);
  }
}

void onActiveSessionChanged(vtkObject*, unsigned long, void*, void*)
{
  if (vtkSMProxyManager::IsInitialized())
  {
    watchSession(vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager());
  }
}

struct InstallLabelColors
{
  InstallLabelColors()
  {
    if (!vtkSMProxyManager::IsInitialized())
    {
      return; // loaded outside a ParaView application: nothing to watch
    }
    vtkSMProxyManager* manager = vtkSMProxyManager::GetProxyManager();
    vtkCallbackCommand* sessions = vtkCallbackCommand::New(); // lives as long as the process
    sessions->SetCallback(onActiveSessionChanged);
    manager->AddObserver(vtkSMProxyManager::ActiveSessionChanged, sessions);
    watchSession(manager->GetActiveSessionProxyManager());
  }
};
// Runs when the plugin library is loaded.
const InstallLabelColors installLabelColors;
} // namespace
