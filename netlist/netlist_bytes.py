"""Netlist files as text: the bounded read of a file's bytes and their decoding, each problem
an input error with its location (a directory, a device, a missing file, binary or non-UTF-8
content, a file over :data:`netlist.limits.FILE_BYTES`)."""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

from .dialect import _NUL_HINT
from .errors import Diagnostic, Location, NetlistError
from .limits import FILE_BYTES

__all__ = ["blank_controls", "decode", "file_stamps", "read_bytes"]


def _utf16(data: bytes) -> str | None:
    """The text of a UTF-16 file with its byte-order mark (LTspice writes its netlists so),
    or None where the bytes are not that (binary data that starts like a mark)."""
    if not data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return None
    try:
        text = data.decode("utf-16")
    except UnicodeDecodeError:
        return None
    plain = sum(c.isascii() and (c.isprintable() or c in "\t\r\n") for c in text)
    return text if plain >= 0.95 * len(text) else None


def decode(data: bytes, file: str, title: bool = True) -> str:
    """Bytes -> text; binary or non-UTF-8 content is an input error with its location
    (``title``: the first line is the title, which :func:`blank_controls` leaves alone).

    A UTF-16 file with its byte-order mark (an LTspice export) is read as such; a file that
    is not UTF-8 but has a few bytes past ASCII among plain text (an LTspice or Windows
    export's ``µ`` for micro, byte 0xB5; an umlaut in a comment) as Latin-1, byte for
    character, as ngspice reads bytes (ngspice 39 reads ``1µ`` in either encoding as 1e-6:
    measured)."""
    utf16 = _utf16(data)
    if utf16 is not None:
        data = utf16.encode("utf-8")
    nul = data.find(b"\x00")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        col = nul - (data.rfind(b"\n", 0, nul) + 1) + 1
        raise NetlistError(Diagnostic(
            "not a text netlist: the file contains NUL bytes (binary data?)",
            Location(file, line, col), _NUL_HINT), file)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        # (a few: plain text with a µ here and there; more is binary data. Not where some
        # are UTF-8 already: a file of both encodings has no one reading)
        mixed = any(c != "\ufffd" and not c.isascii()
                    for c in data.decode("utf-8", errors="replace"))
        if not mixed and sum(b >= 0x80 for b in data) <= max(4, len(data) // 20):
            return decode(data.decode("latin-1").encode("utf-8"), file, title)
        line = data.count(b"\n", 0, exc.start) + 1
        bol = data.rfind(b"\n", 0, exc.start) + 1
        eol = data.find(b"\n", exc.start)
        raw = data[bol: eol if eol >= 0 else len(data)].decode("utf-8", errors="replace")
        col = len(data[bol:exc.start].decode("utf-8", errors="replace")) + 1
        raise NetlistError(Diagnostic(
            f"not UTF-8 text: byte 0x{data[exc.start]:02x} cannot be decoded",
            Location(file, line, col, raw),
            "save the netlist as UTF-8 (or plain ASCII)"), file) from None
    if text.startswith("\ufeff"):
        text = text[1:]
    return blank_controls(text, file, title)


_CONTROL = re.compile("[\x01-\x08\x0b\x0c\x0e-\x1f\x7f]")
# a line whose first character past blanks is a control character, with more after it
_LEADING_CONTROL = re.compile(
    "(?m)^[ \t]*([\x01-\x08\x0b\x0c\x0e-\x1f\x7f])[ \t\x01-\x08\x0b\x0c\x0e-\x1f\x7f]*"
    "(?=[^*\\s\x01-\x08\x0b\x0c\x0e-\x1f\x7f])")


def blank_controls(text: str, file: str, title: bool = True) -> str:
    """Control characters (a schematic tool's export leaves DC3 after values: '1nf\\x13')
    as blanks, one for one (columns kept): ngspice reads such a value up to them.

    One that starts a line (past blanks) is an input error: ngspice 39 does not read that
    line (a form feed makes it a comment, with a warning; another is an 'unknown device
    type' error), where blanking it would read the element on it. (The title line, the
    first of a top-level file when ``title``, is any text.)
    """
    m = _LEADING_CONTROL.search(text, text.find("\n") + 1 if title else 0)
    if m is not None:
        at = m.start(1)
        bol = text.rfind("\n", 0, at) + 1
        eol = text.find("\n", at)
        raw = text[bol: eol if eol >= 0 else len(text)]
        ch = text[at]
        what = ("a form feed: ngspice makes the line a comment (with a warning)" if ch == "\x0c"
                else "ngspice refuses the line ('unknown device type')")
        raise NetlistError(Diagnostic(
            f"control character 0x{ord(ch):02x} at the start of a line: {what}, so the "
            "element on it is not read as written", Location(file, text.count("\n", 0, at) + 1,
                                                             at - bol + 1, _CONTROL.sub(" ", raw)),
            "delete the character (or start the line with '*' to make it a comment)"), file)
    return _CONTROL.sub(" ", text)


def read_bytes(path: str | Path, display: str, at: Location | None) -> bytes:
    """The bytes of a netlist file (``at``: the ``.include`` asking for it, None for the top
    file), bounded by :data:`netlist.limits.FILE_BYTES`. An include must be a regular file
    (``/dev/zero`` or a pipe would never end); the top file may also be a pipe."""
    try:
        limit = FILE_BYTES.value()
    except ValueError as exc:
        raise NetlistError(Diagnostic(str(exc), at, "unset it or give a number of bytes"),
                           display) from None
    try:
        info = os.stat(path)
        mode = info.st_mode
        if stat.S_ISDIR(mode):
            raise NetlistError(Diagnostic(f"'{display}' is a directory, not a netlist file", at,
                                          "give the path of a netlist file"), display)
        if not (stat.S_ISREG(mode) or (at is None and stat.S_ISFIFO(mode))):
            raise NetlistError(Diagnostic(
                f"'{display}' is not a regular file (a device, a pipe or a socket)", at,
                "give the path of a netlist file"), display)
        # (unbuffered: a file object costs more than the read of a netlist, which a design
        # loop does every run)
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_BINARY", 0))
        try:
            # Sized from the file (read(limit + 1) allocates the whole limit, 30 us a
            # netlist); past the size (a pipe, a file grown or replaced since) up to the
            # limit.
            want = min(int(limit), info.st_size) + 1
            data = _read_fd(fd, want)
            if len(data) == want and want <= limit:
                data += _read_fd(fd, int(limit) + 1 - want)
        finally:
            os.close(fd)
    except FileNotFoundError:
        raise NetlistError(Diagnostic(f"file not found: '{display}'", at,
                                      "check the path (relative paths in .include and .lib "
                                      "are relative to the including file)"),
                           display) from None
    except OSError as exc:
        raise NetlistError(Diagnostic(f"cannot read '{display}': {exc.strerror or exc}", at,
                                      "check the path and its permissions"), display) from None
    if len(data) > limit:
        raise NetlistError(Diagnostic(
            f"'{display}' is larger than {limit:.4g} bytes, the limit of a netlist file", at,
            FILE_BYTES.hint("500M")), display)
    return data


#: bytes asked of one read (a file read past its size is read by such pieces)
_CHUNK = 1 << 20


def _read_fd(fd: int, n: int) -> bytes:
    """Up to ``n`` bytes of ``fd``: fewer only at its end (a pipe gives what it holds at a
    time)."""
    parts = []
    got = 0
    while got < n:
        part = os.read(fd, min(n - got, _CHUNK))
        if not part:
            break
        parts.append(part)
        got += len(part)
    return parts[0] if len(parts) == 1 else b"".join(parts)


def file_stamps(files) -> tuple:
    """The modification stamps of ``files`` (None for one that cannot be read): what a
    cache of a parsed netlist compares, so that a long-lived process (a design script, a
    worker) reads a netlist again once it or one of its includes was edited."""
    out = []
    for f in files:
        try:
            st = os.stat(f)
        except OSError:
            out.append(None)
            continue
        out.append((st.st_mtime_ns, st.st_ctime_ns, st.st_size))
    return tuple(out)
