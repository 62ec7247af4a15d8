#include "vtkSMHDTResolutionDomain.h"

#include "vtkObjectFactory.h"
#include "vtkSMIntVectorProperty.h"
#include "vtkSMUncheckedPropertyHelper.h"

#include <string>

namespace
{
// hdt::kMaxResolution and the defaults of xml/HDTVoxelizer.xml (the domain
// is read before the properties that follow Resolution there exist).
constexpr int kMaxResolution = 65536;
constexpr int kDefaultRootGrid = 16;
constexpr int kDefaultLeafSize = 16;

int requiredValue(vtkSMDomain* domain, const char* function, int fallback)
{
  vtkSMProperty* property = domain->GetRequiredProperty(function);
  if (!property || vtkSMUncheckedPropertyHelper(property).GetNumberOfElements() < 1)
  {
    return fallback;
  }
  return vtkSMUncheckedPropertyHelper(property).GetAsInt();
}
} // namespace

vtkStandardNewMacro(vtkSMHDTResolutionDomain);

//------------------------------------------------------------------------------
vtkSMHDTResolutionDomain::vtkSMHDTResolutionDomain() = default;
vtkSMHDTResolutionDomain::~vtkSMHDTResolutionDomain() = default;

//------------------------------------------------------------------------------
std::vector<int> vtkSMHDTResolutionDomain::ValidResolutions(int rootGrid, int leafSize)
{
  std::vector<int> values;
  if (rootGrid < 1 || (leafSize != 8 && leafSize != 16 && leafSize != 32))
  {
    return values;
  }
  for (long long n = static_cast<long long>(rootGrid) * leafSize; n <= kMaxResolution; n *= 2)
  {
    values.push_back(static_cast<int>(n));
  }
  return values;
}

//------------------------------------------------------------------------------
int vtkSMHDTResolutionDomain::ReadXMLAttributes(vtkSMProperty* prop, vtkPVXMLElement* element)
{
  if (!this->Superclass::ReadXMLAttributes(prop, element))
  {
    return 0;
  }
  this->Update(nullptr);
  return 1;
}

//------------------------------------------------------------------------------
void vtkSMHDTResolutionDomain::Update(vtkSMProperty*)
{
  const int rootGrid = requiredValue(this, "RootGrid", kDefaultRootGrid);
  const int leafSize = requiredValue(this, "LeafSize", kDefaultLeafSize);
  if (rootGrid == this->LastRootGrid && leafSize == this->LastLeafSize)
  {
    return;
  }
  this->LastRootGrid = rootGrid;
  this->LastLeafSize = leafSize;
  this->RemoveAllEntries();
  for (int n : ValidResolutions(rootGrid, leafSize))
  {
    this->AddEntry(std::to_string(n).c_str(), n);
  }
  this->DomainModified();
}

//------------------------------------------------------------------------------
void vtkSMHDTResolutionDomain::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "RootGrid: " << this->LastRootGrid << "\n";
  os << indent << "LeafSize: " << this->LastLeafSize << "\n";
}
