#!/usr/bin/env python3
"""Bundle hullpipe binaries with their shared libraries for a machine without
Debian's packages (a GPU machine with another distribution, no package registry).

    scripts/bundle_binaries.py OUT build/bin/hullpipe_bench build/bin/recon_node ...

OUT/bin gets the binaries (stripped), OUT/lib the libraries they load: the ones
hullpipe calls into (OpenCV, Cyclone DDS, FFmpeg's decoders, yaml-cpp, spdlog...)
copied and stripped, and every other library in the closure (GDAL, GStreamer, Qt,
codecs FFmpeg links but the rig's MPEG-4 files never use...) replaced by a stub with
the same soname, version nodes and symbols, each of which returns 0 and says so on
stderr (OpenCV registers its GDAL and EXR codecs as it loads); a stub holds only the symbols the carried files import. That keeps the bundle under a few tens of MiB instead of ~300 MiB.
glibc and the GL/EGL loaders (libglvnd) are left to the target machine, whose
driver provides them. Run with: LD_LIBRARY_PATH=OUT/lib OUT/bin/NAME.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

# Provided by the target machine: glibc, the dynamic loader and libglvnd's GL/EGL.
SYSTEM = re.compile(r"^(libc|libm|libpthread|libdl|librt|ld-linux-x86-64|linux-vdso|libresolv|"
                    r"libGL|libEGL|libOpenGL|libGLX|libGLdispatch|libGLESv2)\.so")
# Carried as they are: what hullpipe's binaries call at run time (Assimp with
# its own needs: sim_node imports the scenes' CAD models).
REAL = re.compile(r"^(libopencv_(?!highgui)\w+|libddsc|libyaml-cpp|libspdlog|libfmt|libstdc\+\+|libgcc_s|"
                  r"libtbb|liblapack|libblas|libgfortran|libquadmath|libz|liblzma|libxml2|"
                  r"libavcodec|libavformat|libavutil|libswscale|libswresample|libjpeg|libpng16|"
                  r"libgomp|libdrm|libexpat|libwebp|libsharpyuv|libgme|libopenmpt|"
                  r"libassimp|libdraco|libminizip)\.so")

# Defined by the linker or crt files in every shared library.
LINKER_PROVIDED = {"_init", "_fini", "_edata", "_end", "__bss_start", "_DYNAMIC",
                   "_GLOBAL_OFFSET_TABLE_"}


def resolve(binaries):
    """Maps soname -> path for the libraries to carry: what the binaries and the
    carried libraries need, not looking inside the libraries to be stubbed."""
    paths = {}
    for b in binaries:
        out = subprocess.run(["ldd", b], check=True, capture_output=True, text=True).stdout
        for line in out.splitlines():
            m = re.match(r"\s*(\S+) => (/\S+)", line)
            if m:
                paths[m.group(1)] = m.group(2)
    carried, real, todo = {}, set(), list(binaries)
    # What the target's GL loaders need themselves (libGLX needs libX11) is carried
    # as it is, or a stub would shadow it for them.
    for soname, path in paths.items():
        if SYSTEM.match(soname) and soname.startswith("libGL"):
            out = subprocess.run(["ldd", path], check=True, capture_output=True, text=True).stdout
            for dep, dep_path in re.findall(r"\s*(\S+) => (/\S+)", out):
                if not SYSTEM.match(dep):
                    real.add(dep)
                    carried[dep] = dep_path
    while todo:
        f = todo.pop()
        for soname in needed(f):
            if SYSTEM.match(soname) or soname in carried:
                continue
            carried[soname] = paths[soname]
            if REAL.match(soname) or soname in real:
                real.add(soname)
                todo.append(paths[soname])
    return carried, real


def needed(path):
    out = subprocess.run(["readelf", "-d", "-W", path], check=True, capture_output=True,
                         text=True).stdout
    return re.findall(r"\(NEEDED\)\s+Shared library: \[(\S+)\]", out)


def imported(paths):
    """The symbol names (without version) that these objects import."""
    names = set()
    for p in paths:
        out = subprocess.run(["readelf", "--dyn-syms", "-W", p], check=True, capture_output=True,
                             text=True).stdout
        for line in out.splitlines():
            f = line.split()
            if len(f) >= 8 and f[6] == "UND":
                names.add(f[7].split("@")[0])
    return names


def stub(soname, path, out_dir, work, wanted):
    """Writes a library with `soname`, the version nodes of `path` and those of its
    defined dynamic symbols in `wanted`; each function returns 0 and names itself on
    stderr the first time."""
    syms = subprocess.run(["readelf", "--dyn-syms", "-W", path], check=True, capture_output=True,
                          text=True).stdout
    versions = []
    c = ['#include <stdio.h>',
         'static void note(const char* s) { fprintf(stderr, "bundle: %s called in the stub ' +
         soname + ', returns 0\\n", s); }']
    default_by_version = {}
    n = 0
    for line in syms.splitlines():
        f = line.split()
        if len(f) < 8 or not f[0].rstrip(":").isdigit() or f[6] in ("UND", "ABS") or f[4] == "LOCAL":
            continue
        kind, size, name = f[3], int(f[2], 0) if f[2].startswith("0x") else int(f[2]), f[7]
        if kind not in ("FUNC", "IFUNC", "OBJECT", "TLS", "NOTYPE"):
            continue
        base, sep, ver = name.partition("@")
        default = ver.startswith("@")
        ver = ver.lstrip("@")
        if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", base) or base in LINKER_PROVIDED:
            continue
        if ver and ver not in versions:
            versions.append(ver)
        if base not in wanted:
            continue
        n += 1
        ident = "hp_s%d" % n
        if kind in ("FUNC", "IFUNC", "NOTYPE"):
            c.append('long %s(void) { static int once; if (!once++) note("%s"); return 0; }' %
                     (ident, base))
        elif kind == "TLS":
            c.append('__thread char %s[%d] __attribute__((aligned(16)));' % (ident, max(size, 1)))
        else:
            c.append('char %s[%d] __attribute__((aligned(16)));' % (ident, max(size, 1)))
        if ver and default:
            default_by_version.setdefault(ver, []).append((ident, base))
        elif ver:
            c.append('__asm__(".symver %s, %s@%s");' % (ident, base, ver))
        else:
            default_by_version.setdefault("", []).append((ident, base))
    # Default-version and unversioned symbols: rename through asm aliases.
    for ver, pairs in default_by_version.items():
        for ident, base in pairs:
            if ver:
                c.append('__asm__(".symver %s, %s@@%s");' % (ident, base, ver))
            else:
                c.append('extern __typeof__(%s) %s_alias __attribute__((alias("%s")));' %
                         (ident, ident, ident))
                c.append('__asm__(".globl %s\\n.set %s, %s");' % (base, base, ident))
    src = os.path.join(work, soname + ".c")
    with open(src, "w") as fh:
        fh.write("\n".join(c) + "\n")
    cmd = ["gcc", "-shared", "-fPIC", "-O0", "-w", "-Wl,-soname," + soname, "-o",
           os.path.join(out_dir, soname), src]
    if versions:
        script = os.path.join(work, soname + ".map")
        with open(script, "w") as fh:
            fh.write("".join("%s { global: *; };\n" % v for v in versions[:1]))
            fh.write("".join("%s { };\n" % v for v in versions[1:]))
        cmd.insert(1, "-Wl,--version-script=" + script)
    subprocess.run(cmd, check=True)


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: bundle_binaries.py OUT BINARY...")
    out, binaries = sys.argv[1], sys.argv[2:]
    os.makedirs(os.path.join(out, "bin"), exist_ok=True)
    os.makedirs(os.path.join(out, "lib"), exist_ok=True)
    libs, real = resolve(binaries)
    wanted = imported(list(binaries) + [p for s, p in libs.items() if s in real])
    with tempfile.TemporaryDirectory() as work:
        for soname, path in sorted(libs.items()):
            dest = os.path.join(out, "lib", soname)
            if soname in real:
                shutil.copy(path, dest)
                subprocess.run(["strip", "--strip-unneeded", dest], check=True)
            else:
                stub(soname, path, os.path.join(out, "lib"), work, wanted)
    for b in binaries:
        dest = os.path.join(out, "bin", os.path.basename(b))
        shutil.copy(b, dest)
        subprocess.run(["strip", "--strip-unneeded", dest], check=True)
    print("bundle: %d binaries, %d libraries carried, %d stubbed, in %s" %
          (len(binaries), len(real), len(libs) - len(real), out))


if __name__ == "__main__":
    main()
