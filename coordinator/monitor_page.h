// The monitor's live page (monitor_page.html, built into the program so that `hemocosim monitor
// --http` needs no files beside it).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>

namespace hemo {
const std::string& monitor_page_html();
}
