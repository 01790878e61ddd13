#include "xcb_window.h"

#include "error.h"

#include <cstdlib>
#include <cstring>

namespace atrium {

namespace {

xcb_atom_t intern_atom(xcb_connection_t *connection, const char *name) {
    const xcb_intern_atom_cookie_t cookie = xcb_intern_atom(connection, 0, uint16_t(std::strlen(name)), name);
    xcb_intern_atom_reply_t *reply = xcb_intern_atom_reply(connection, cookie, nullptr);
    const xcb_atom_t atom = reply ? reply->atom : xcb_atom_t(XCB_ATOM_NONE);
    std::free(reply);
    return atom;
}

} // namespace

XcbWindow::XcbWindow(uint32_t width, uint32_t height, const std::string &title) {
    int screen_number = 0;
    connection_ = xcb_connect(nullptr, &screen_number);
    if (xcb_connection_has_error(connection_)) {
        xcb_disconnect(connection_);
        const char *display = std::getenv("DISPLAY");
        throw Error(display ? std::string("cannot open X display '") + display + "'"
                            : std::string("cannot open X display: DISPLAY is not set"));
    }
    xcb_screen_iterator_t it = xcb_setup_roots_iterator(xcb_get_setup(connection_));
    for (int i = 0; i < screen_number && it.rem > 0; ++i)
        xcb_screen_next(&it);
    const xcb_screen_t *screen = it.data;

    window_ = xcb_generate_id(connection_);
    const uint32_t values[] = {screen->black_pixel, XCB_EVENT_MASK_STRUCTURE_NOTIFY};
    xcb_create_window(connection_, XCB_COPY_FROM_PARENT, window_, screen->root, 0, 0, uint16_t(width),
                      uint16_t(height), 0, XCB_WINDOW_CLASS_INPUT_OUTPUT, screen->root_visual,
                      XCB_CW_BACK_PIXEL | XCB_CW_EVENT_MASK, values);
    xcb_change_property(connection_, XCB_PROP_MODE_REPLACE, window_, XCB_ATOM_WM_NAME, XCB_ATOM_STRING, 8,
                        uint32_t(title.size()), title.data());

    // WM_NORMAL_HINTS: user-specified position and size (flags USPosition | USSize | PMinSize |
    // PMaxSize), so that a window manager, if any, keeps the window at (0, 0) and unresizable.
    uint32_t hints[18] = {};
    hints[0] = 1u | 2u | 16u | 32u;
    hints[3] = width;
    hints[4] = height;
    hints[5] = hints[7] = width;
    hints[6] = hints[8] = height;
    xcb_change_property(connection_, XCB_PROP_MODE_REPLACE, window_, XCB_ATOM_WM_NORMAL_HINTS,
                        XCB_ATOM_WM_SIZE_HINTS, 32, 18, hints);

    wm_protocols_ = intern_atom(connection_, "WM_PROTOCOLS");
    wm_delete_window_ = intern_atom(connection_, "WM_DELETE_WINDOW");
    if (wm_protocols_ != XCB_ATOM_NONE && wm_delete_window_ != XCB_ATOM_NONE)
        xcb_change_property(connection_, XCB_PROP_MODE_REPLACE, window_, wm_protocols_, XCB_ATOM_ATOM, 32, 1,
                            &wm_delete_window_);

    xcb_map_window(connection_, window_);
    sync();
}

XcbWindow::~XcbWindow() {
    xcb_destroy_window(connection_, window_);
    xcb_disconnect(connection_);
}

void XcbWindow::resize(uint32_t width, uint32_t height) {
    const uint32_t values[] = {width, height};
    xcb_configure_window(connection_, window_, XCB_CONFIG_WINDOW_WIDTH | XCB_CONFIG_WINDOW_HEIGHT, values);
    sync();
}

bool XcbWindow::close_requested() {
    while (xcb_generic_event_t *event = xcb_poll_for_event(connection_)) {
        if ((event->response_type & 0x7f) == XCB_CLIENT_MESSAGE) {
            const auto *message = reinterpret_cast<const xcb_client_message_event_t *>(event);
            if (message->type == wm_protocols_ && message->data.data32[0] == wm_delete_window_)
                close_requested_ = true;
        }
        std::free(event);
    }
    return close_requested_;
}

void XcbWindow::sync() const {
    std::free(xcb_get_input_focus_reply(connection_, xcb_get_input_focus(connection_), nullptr));
}

} // namespace atrium
