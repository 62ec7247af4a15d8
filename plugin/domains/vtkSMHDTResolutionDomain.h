/**
 * @class vtkSMHDTResolutionDomain
 * @brief The valid Resolutions for the current Root Grid Size and Leaf Grid Size.
 *
 * An enumeration domain whose entries are N = R x 2^h x L (h >= 0, N <= 65536),
 * the resolutions hdt::validateConfig accepts, for R and L read from the
 * required properties "RootGrid" and "LeafSize" (unchecked values, so the combo
 * follows the panel before Apply). ParaView's combo box (pqComboBoxDomain)
 * rebuilds its list on every DomainModifiedEvent. The current value is left as
 * it is when it falls out of the list: the filter then names the nearest valid
 * values in its error, and the user picks one.
 *
 * XML:
 * @code{xml}
 * <HDTResolutionDomain name="enum">
 *   <RequiredProperties>
 *     <Property name="RootGridSize" function="RootGrid" />
 *     <Property name="LeafGridSize" function="LeafSize" />
 *   </RequiredProperties>
 * </HDTResolutionDomain>
 * @endcode
 */
#ifndef vtkSMHDTResolutionDomain_h
#define vtkSMHDTResolutionDomain_h

#include "HDTServerManagerModule.h" // for the export macro
#include "vtkSMEnumerationDomain.h"

#include <vector>

class HDTSERVERMANAGER_EXPORT vtkSMHDTResolutionDomain : public vtkSMEnumerationDomain
{
public:
  static vtkSMHDTResolutionDomain* New();
  vtkTypeMacro(vtkSMHDTResolutionDomain, vtkSMEnumerationDomain);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /**
   * Recomputes the entries from the required properties.
   */
  void Update(vtkSMProperty* requestingProperty) override;

  /**
   * The valid resolutions for root grid size R and leaf grid size L, ascending
   * (empty when R or L is itself invalid). Kept in step with
   * hdt::validateConfig (core/src/config.cpp) by the pvpython test.
   */
  static std::vector<int> ValidResolutions(int rootGrid, int leafSize);

protected:
  vtkSMHDTResolutionDomain();
  ~vtkSMHDTResolutionDomain() override;

  int ReadXMLAttributes(vtkSMProperty* prop, vtkPVXMLElement* element) override;

private:
  vtkSMHDTResolutionDomain(const vtkSMHDTResolutionDomain&) = delete;
  void operator=(const vtkSMHDTResolutionDomain&) = delete;

  int LastRootGrid = -1;
  int LastLeafSize = -1;
};

#endif
