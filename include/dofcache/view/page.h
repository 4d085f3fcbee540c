#pragma once
// The page of `dofcache view`: src/view/page/index.html (HTML, CSS and JavaScript in one file, no
// network access, no build step), embedded into the library at build time.
#include <string>

namespace dofcache::view {

const std::string& page_html();

}  // namespace dofcache::view
