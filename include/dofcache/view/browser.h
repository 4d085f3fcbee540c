#pragma once
// Opening the viewer's address in the user's browser (`dofcache view --open`).
#include <string>

namespace dofcache::view {

// A program that opens URLs in the user's browser: $BROWSER, else xdg-open (Linux) or open
// (macOS) if on the PATH. Empty if none is known.
std::string browser_command();

// Starts browser_command() with `url`, without a shell (so nothing in either is interpreted);
// false if no browser is known or it could not be started.
bool open_in_browser(const std::string& url);

}  // namespace dofcache::view
