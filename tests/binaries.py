"""What a shared library imports and exports, read from the file itself (ELF, PE, Mach-O).

Written from the formats' specifications (the System V gABI and the GNU
symbol-versioning extension, Microsoft's PE/COFF specification, Apple's
<mach-o/loader.h> and <mach-o/fat.h>) so that the tests judge the compilers'
output with no tool of the same toolchain: 64-bit little-endian files only,
which is every target the FMUs ship.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field


@dataclass
class Linkage:
    """A library's dependencies and symbols.

    libraries : the shared libraries it loads (ELF DT_NEEDED, PE import DLLs, Mach-O LC_LOAD_DYLIB)
    imports : symbol -> version (ELF: e.g. ``GLIBC_2.2.5``; "" where unversioned or not ELF)
    exports : the symbols it defines for others (Mach-O's leading underscore removed)
    min_os : Mach-O only: the oldest macOS version it loads on, as (major, minor)
    """

    libraries: list[str] = field(default_factory=list)
    imports: dict[str, str] = field(default_factory=dict)
    exports: list[str] = field(default_factory=list)
    min_os: tuple[int, int] | None = None


def _cstr(data: bytes, at: int) -> str:
    return data[at:data.index(b"\0", at)].decode()


def read(data: bytes) -> list[tuple[str, Linkage]]:
    """(architecture, linkage) of each binary in ``data`` (a universal Mach-O holds several)."""
    if data[:4] == b"\x7fELF":
        return [_elf(data)]
    if data[:2] == b"MZ":
        return [_pe(data)]
    if data[:4] == b"\xca\xfe\xba\xbe":
        (n,) = struct.unpack_from(">I", data, 4)
        out = []
        for k in range(n):
            _, _, offset, size, _ = struct.unpack_from(">iIIII", data, 8 + 20 * k)
            out += read(data[offset:offset + size])
        return out
    if data[:4] == b"\xcf\xfa\xed\xfe":
        return [_macho(data)]
    raise ValueError("not a 64-bit ELF, PE or Mach-O file")


def _elf(data: bytes) -> tuple[str, Linkage]:
    if data[4] != 2 or data[5] != 1:
        raise ValueError("not a 64-bit little-endian ELF file")
    (machine,) = struct.unpack_from("<H", data, 0x12)
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + k * shentsize) for k in range(shnum)]
    by_type = {}
    for s in sections:
        by_type.setdefault(s[1], s)
    SHT_DYNAMIC, SHT_DYNSYM, SHT_VERNEED, SHT_VERSYM = 6, 11, 0x6FFFFFFE, 0x6FFFFFFF
    dynsym = by_type[SHT_DYNSYM]
    strtab = sections[dynsym[6]][4]
    link = Linkage()
    # version index -> name, from the version needs
    names = {}
    if SHT_VERNEED in by_type:
        vn = by_type[SHT_VERNEED]
        at, vstr = vn[4], sections[vn[6]][4]
        for _ in range(vn[7]):
            _, cnt, _, aux, nxt = struct.unpack_from("<HHIII", data, at)
            a = at + aux
            for _ in range(cnt):
                _, _, other, name, anext = struct.unpack_from("<IHHII", data, a)
                names[other] = _cstr(data, vstr + name)
                a += anext
            at += nxt
    versym = by_type.get(SHT_VERSYM)
    for k in range(1, dynsym[5] // 24):
        name, info, other, shndx, _, _ = struct.unpack_from("<IBBHQQ", data, dynsym[4] + 24 * k)
        bind, visibility = info >> 4, other & 3
        sym = _cstr(data, strtab + name)
        if shndx == 0:
            index = struct.unpack_from("<H", data, versym[4] + 2 * k)[0] & 0x7FFF if versym else 0
            link.imports[sym] = names.get(index, "")
        elif bind in (1, 2) and visibility in (0, 3):  # global or weak, default or protected
            link.exports.append(sym)
    if SHT_DYNAMIC in by_type:
        dyn = by_type[SHT_DYNAMIC]
        for k in range(dyn[5] // 16):
            tag, val = struct.unpack_from("<qQ", data, dyn[4] + 16 * k)
            if tag == 1:  # DT_NEEDED
                link.libraries.append(_cstr(data, strtab + val))
    return {0x3E: "x86_64", 0xB7: "aarch64"}.get(machine, hex(machine)), link


def _pe(data: bytes) -> tuple[str, Linkage]:
    (pe,) = struct.unpack_from("<I", data, 0x3C)
    if data[pe:pe + 4] != b"PE\0\0":
        raise ValueError("not a PE file")
    machine, nsections, _, _, _, opt_size, _ = struct.unpack_from("<HHIIIHH", data, pe + 4)
    opt = pe + 24
    if struct.unpack_from("<H", data, opt)[0] != 0x20B:
        raise ValueError("not a PE32+ (64-bit) file")
    export_rva, _, import_rva, _ = struct.unpack_from("<IIII", data, opt + 112)
    table = opt + opt_size
    sections = [struct.unpack_from("<8sIIII", data, table + 40 * k) for k in range(nsections)]

    def offset(rva: int) -> int:
        for _, vsize, va, raw_size, raw in sections:
            if va <= rva < va + max(vsize, raw_size):
                return rva - va + raw
        raise ValueError(f"RVA {rva:#x} in no section")

    link = Linkage()
    if import_rva:
        at = offset(import_rva)
        while True:
            lookup, _, _, name, thunk = struct.unpack_from("<IIIII", data, at)
            if name == 0:
                break
            link.libraries.append(_cstr(data, offset(name)))
            t = offset(lookup or thunk)
            while True:
                (entry,) = struct.unpack_from("<Q", data, t)
                if entry == 0:
                    break
                if not entry >> 63:  # by name: a hint, then the name
                    link.imports[_cstr(data, offset(entry & 0x7FFFFFFF) + 2)] = ""
                t += 8
            at += 20
    if export_rva:
        e = offset(export_rva)
        n_names, _, names_rva = struct.unpack_from("<III", data, e + 24)
        for k in range(n_names):
            (rva,) = struct.unpack_from("<I", data, offset(names_rva) + 4 * k)
            link.exports.append(_cstr(data, offset(rva)))
    return {0x8664: "x86_64", 0xAA64: "aarch64"}.get(machine, hex(machine)), link


def _macho(data: bytes) -> tuple[str, Linkage]:
    _, cputype, _, _, ncmds, _, _, _ = struct.unpack_from("<IiIIIIII", data, 0)
    LC_SYMTAB, LC_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB, LC_BUILD_VERSION = (
        0x2, 0xC, 0x80000018, 0x8000001F, 0x32)
    link, at = Linkage(), 32
    for _ in range(ncmds):
        cmd, size = struct.unpack_from("<II", data, at)
        if cmd in (LC_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB):
            (name,) = struct.unpack_from("<I", data, at + 8)
            link.libraries.append(_cstr(data, at + name))
        elif cmd == LC_BUILD_VERSION:
            (minos,) = struct.unpack_from("<I", data, at + 12)
            link.min_os = (minos >> 16, (minos >> 8) & 0xFF)
        elif cmd == LC_SYMTAB:
            symoff, nsyms, stroff, _ = struct.unpack_from("<IIII", data, at + 8)
            for k in range(nsyms):
                strx, ntype, _, _, _ = struct.unpack_from("<IBBHQ", data, symoff + 16 * k)
                if ntype & 0xE0:  # a debugger's entry
                    continue
                name = _cstr(data, stroff + strx)
                name = name[1:] if name.startswith("_") else name
                if ntype & 0x01 and (ntype & 0x0E) == 0x0:  # external, undefined
                    link.imports[name] = ""
                elif ntype & 0x01 and not ntype & 0x10 and (ntype & 0x0E) == 0xE:  # external, in a section
                    link.exports.append(name)
        at += size
    return {0x01000007: "x86_64", 0x0100000C: "aarch64"}.get(cputype, hex(cputype)), link
