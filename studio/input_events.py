"""Keys and characters from GLFW to imgui, a frame's worth at a time, in order, none dropped.

imgui's GLFW backend hands each event to imgui the moment GLFW reports it, and reads the modifier
keys' state from GLFW at that moment. When a frame takes long (software GL on a busy machine:
70-130 ms was measured), one poll of the window brings A down, Ctrl up and A up together (Ctrl
down came a poll earlier). imgui then applies A and the Ctrl release in the same frame, and
Ctrl+A selects nothing (in a real X window driven by xdotool it failed in 3 of 4 tries).

So the app installs the key and character callbacks itself (:class:`KeyQueue`): events wait in a
queue and :meth:`KeyQueue.feed` hands them to imgui at the start of a frame. It stops before a
modifier is released once a key it modified was pressed in the same frame: the release (and what
follows) waits for the next frame. The modifier state imgui gets is the events' own, in order.
Mouse and window events still go straight to imgui's backend.

While a text field has the keyboard, the presses and releases of keys that type a character
(letters, digits, punctuation, space) without Ctrl, Alt or Super are not handed over: the field
takes the characters, and imgui, which spreads a key's press and release over two frames, would
otherwise take in one typed character a frame (on 150 ms frames a typed path lagged seconds
behind). Keys imgui saw go down always come up.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

import glfw
from imgui_bundle import imgui

K = imgui.Key
# modifier keys -> the imgui modifier they hold down
MODIFIERS = {glfw.KEY_LEFT_CONTROL: K.mod_ctrl, glfw.KEY_RIGHT_CONTROL: K.mod_ctrl,
             glfw.KEY_LEFT_SHIFT: K.mod_shift, glfw.KEY_RIGHT_SHIFT: K.mod_shift,
             glfw.KEY_LEFT_ALT: K.mod_alt, glfw.KEY_RIGHT_ALT: K.mod_alt,
             glfw.KEY_LEFT_SUPER: K.mod_super, glfw.KEY_RIGHT_SUPER: K.mod_super}
CHORD_MODIFIERS = (K.mod_ctrl, K.mod_alt, K.mod_super)  # a key pressed with one of these is a shortcut
TYPING_KEYS = range(glfw.KEY_SPACE, glfw.KEY_GRAVE_ACCENT + 1)  # keys that type a character (not the keypad's)

_NAMED = {
    "TAB": "tab", "LEFT": "left_arrow", "RIGHT": "right_arrow", "UP": "up_arrow", "DOWN": "down_arrow",
    "PAGE_UP": "page_up", "PAGE_DOWN": "page_down", "HOME": "home", "END": "end", "INSERT": "insert",
    "DELETE": "delete", "BACKSPACE": "backspace", "SPACE": "space", "ENTER": "enter", "ESCAPE": "escape",
    "APOSTROPHE": "apostrophe", "COMMA": "comma", "MINUS": "minus", "PERIOD": "period", "SLASH": "slash",
    "SEMICOLON": "semicolon", "EQUAL": "equal", "LEFT_BRACKET": "left_bracket", "BACKSLASH": "backslash",
    "RIGHT_BRACKET": "right_bracket", "GRAVE_ACCENT": "grave_accent", "CAPS_LOCK": "caps_lock",
    "SCROLL_LOCK": "scroll_lock", "NUM_LOCK": "num_lock", "PRINT_SCREEN": "print_screen", "PAUSE": "pause",
    "KP_DECIMAL": "keypad_decimal", "KP_DIVIDE": "keypad_divide", "KP_MULTIPLY": "keypad_multiply",
    "KP_SUBTRACT": "keypad_subtract", "KP_ADD": "keypad_add", "KP_ENTER": "keypad_enter", "KP_EQUAL": "keypad_equal",
    "LEFT_SHIFT": "left_shift", "LEFT_CONTROL": "left_ctrl", "LEFT_ALT": "left_alt", "LEFT_SUPER": "left_super",
    "RIGHT_SHIFT": "right_shift", "RIGHT_CONTROL": "right_ctrl", "RIGHT_ALT": "right_alt",
    "RIGHT_SUPER": "right_super", "MENU": "menu",
}
# characters a layout may put on a key -> the GLFW key imgui names after them (as imgui's backend
# translates them: Ctrl+A is the key that types 'a' on the user's layout)
_CHAR_KEYS = {"`": glfw.KEY_GRAVE_ACCENT, "-": glfw.KEY_MINUS, "=": glfw.KEY_EQUAL, "[": glfw.KEY_LEFT_BRACKET,
              "]": glfw.KEY_RIGHT_BRACKET, "\\": glfw.KEY_BACKSLASH, ",": glfw.KEY_COMMA, ";": glfw.KEY_SEMICOLON,
              "'": glfw.KEY_APOSTROPHE, ".": glfw.KEY_PERIOD, "/": glfw.KEY_SLASH}


def _key_table() -> dict[int, imgui.Key]:
    table = {getattr(glfw, f"KEY_{name}"): getattr(K, key) for name, key in _NAMED.items()}
    table.update({glfw.KEY_A + i: getattr(K, chr(ord("a") + i)) for i in range(26)})
    table.update({glfw.KEY_0 + i: getattr(K, f"_{i}") for i in range(10)})
    table.update({glfw.KEY_KP_0 + i: getattr(K, f"keypad{i}") for i in range(10)})
    table.update({getattr(glfw, f"KEY_F{i}"): getattr(K, f"f{i}") for i in range(1, 25)})
    return table


KEYS = _key_table()


def translated(key: int, name: str | None) -> int:
    """The key as the user's layout labels it: ``name`` is GLFW's name for the key (one character
    for printable keys); keypad keys stay as they are."""
    if glfw.KEY_KP_0 <= key <= glfw.KEY_KP_EQUAL or not name or len(name) != 1:
        return key
    c = name.lower()
    if "0" <= c <= "9":
        return glfw.KEY_0 + ord(c) - ord("0")
    if "a" <= c <= "z":
        return glfw.KEY_A + ord(c) - ord("a")
    return _CHAR_KEYS.get(c, key)


class KeyQueue:
    """GLFW key and character events, held until :meth:`feed` hands them to imgui."""

    def __init__(self):
        self._events: deque = deque()
        self._held: set[int] = set()  # modifier keys down, as far as the events fed so far say
        self._down: set[int] = set()  # other keys imgui was told are down

    # ---- GLFW callbacks (the UI thread, while it polls the window) -----------------------
    def key(self, key: int, scancode: int, action: int, name: str | None = None) -> None:
        """A key event; ``name``: GLFW's name for it (:func:`glfw.get_key_name`). Repeats are
        left to imgui, which makes its own."""
        if action in (glfw.PRESS, glfw.RELEASE):
            self._events.append((translated(key, name) if key not in MODIFIERS else key, action == glfw.PRESS))

    def char(self, codepoint: int) -> None:
        self._events.append((None, codepoint))

    def focus_lost(self) -> None:
        """imgui forgets the keys held when the window loses focus; so does the queue."""
        self._held.clear()
        self._down.clear()

    @property
    def pending(self) -> int:
        return len(self._events)

    # ---- the frame --------------------------------------------------------------------------
    def feed(self, io: imgui.IO) -> int:
        """Hand queued events to imgui, up to the release of a modifier that a key pressed in
        this batch went with; returns how many were taken from the queue."""
        chord, n, typing = False, 0, io.want_text_input
        while self._events:
            key, value = self._events[0]
            if key is None:
                io.add_input_character(value)
            elif key in MODIFIERS:
                if not value and chord:
                    break  # Ctrl up after Ctrl+A down: next frame, so imgui sees the chord
                self._held.add(key) if value else self._held.discard(key)
                mod = MODIFIERS[key]
                io.add_key_event(mod, any(MODIFIERS[k] == mod for k in self._held))
                io.add_key_event(KEYS[key], value)
            else:
                shortcut = any(MODIFIERS[k] in CHORD_MODIFIERS for k in self._held)
                chord = chord or (value and shortcut)
                typed = typing and key in TYPING_KEYS and not shortcut  # the field takes its character
                if key in KEYS and not (typed if value else key not in self._down):
                    io.add_key_event(KEYS[key], value)
                    self._down.add(key) if value else self._down.discard(key)
            self._events.popleft()
            n += 1
        return n


def install_callbacks(window, window_addr: int, keys: KeyQueue, on_input: Callable[[], None],
                      on_drop: Callable[[list[str]], None]) -> None:
    """The window's GLFW callbacks, installed instead of imgui's backend's (initialise it with
    ``install_callbacks=False``): keys and characters go to ``keys``, mouse and window events to
    imgui's backend at once, dropped paths to ``on_drop``; every event calls ``on_input``."""
    b = imgui.backends

    def on_key(_w, key, scancode, action, _mods):
        keys.key(key, scancode, action, glfw.get_key_name(key, scancode))
        on_input()

    def on_char(_w, codepoint):
        keys.char(codepoint)
        on_input()

    def on_focus(_w, focused):
        b.glfw_window_focus_callback(window_addr, focused)
        if not focused:
            keys.focus_lost()
        on_input()

    def forward(to_imgui):
        def callback(_w, *args):
            to_imgui(window_addr, *args)
            on_input()
        return callback

    def dropped(_w, paths):
        on_drop([str(p) for p in paths])
        on_input()

    glfw.set_key_callback(window, on_key)
    glfw.set_char_callback(window, on_char)
    glfw.set_window_focus_callback(window, on_focus)
    glfw.set_cursor_enter_callback(window, forward(b.glfw_cursor_enter_callback))
    glfw.set_cursor_pos_callback(window, forward(b.glfw_cursor_pos_callback))
    glfw.set_mouse_button_callback(window, forward(b.glfw_mouse_button_callback))
    glfw.set_scroll_callback(window, forward(b.glfw_scroll_callback))
    glfw.set_drop_callback(window, dropped)
    for install in (glfw.set_framebuffer_size_callback, glfw.set_window_refresh_callback,
                    glfw.set_window_iconify_callback):
        install(window, lambda *_: on_input())
