// The X11 window the swapchain presents to.
#pragma once

#include <cstdint>
#include <string>

#include <xcb/xcb.h>

namespace atrium {

class XcbWindow {
public:
    // Creates and maps a width x height window at (0, 0) on the default screen of $DISPLAY.
    // Throws Error if the display cannot be opened.
    XcbWindow(uint32_t width, uint32_t height, const std::string &title);
    ~XcbWindow();
    XcbWindow(const XcbWindow &) = delete;
    XcbWindow &operator=(const XcbWindow &) = delete;

    xcb_connection_t *connection() const { return connection_; }
    xcb_window_t window() const { return window_; }

    // Asks the X server for a new size; the swapchain notices at its next acquire or present.
    void resize(uint32_t width, uint32_t height);

    // Drains pending events; returns true once the window manager has asked the window to close.
    bool close_requested();

    // Round trip to the X server: when this returns, the server has processed every request sent
    // on this connection, including the images the swapchain put on the window.
    void sync() const;

private:
    xcb_connection_t *connection_ = nullptr;
    xcb_window_t window_ = 0;
    xcb_atom_t wm_protocols_ = XCB_ATOM_NONE;
    xcb_atom_t wm_delete_window_ = XCB_ATOM_NONE;
    bool close_requested_ = false;
};

} // namespace atrium
