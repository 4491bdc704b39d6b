"""test_vzeroupper.py: the kernels' AVX code, read in its disassembly,
leaves no ymm or zmm register's upper half set where code built for the
baseline may run next: at a return, a tail call or a call out (a call
to a function of the library that has only VEX code may pass them). Such code
(the callers, libm's log and exp) would then pay the AVX-SSE transition
on every SSE instruction until something cleared them: ramp_finish_avx2
() once took its lanes in 256-bit registers, gcc put no vzeroupper there,
and the velocity stage took twice its CPU time. test-kernels' upper-clean
cases check the same at run time on the paths they run; this check
follows every path of every function, whichever CPU builds it.

    python3 tests/test_vzeroupper.py build/gst/libsonarkernels.a
"""

import re
import shutil
import subprocess
import sys

from taptest import BUILD_DIR, Skip, run_all, test

LIBRARY = (sys.argv[1] if len(sys.argv) > 1
           else str(BUILD_DIR / "gst" / "libsonarkernels.a"))

# ymm0-15 and zmm0-15: the registers whose upper halves SSE code shares
# (zmm16-31 are out of its reach: no penalty, and vzeroupper leaves them).
UPPER = re.compile(r"%[yz]mm([0-9]+)\b")
DIRECT = re.compile(r"^\S+\s+([0-9a-f]+) <([^>+]+)(\+0x[0-9a-f]+)?>")


def functions(disassembly):
    """{name: [(address, instruction)]} of objdump -d's text."""
    found, current = {}, None
    for line in disassembly.splitlines():
        m = re.match(r"^([0-9a-f]+) <(.+)>:$", line)
        if m:
            current = found.setdefault(m.group(2), [])
            continue
        m = re.match(r"^\s+([0-9a-f]+):\s+(\S.*)$", line)
        if m and current is not None:
            current.append((int(m.group(1), 16), m.group(2).strip()))
    return found


def touches_upper(instruction):
    return any(int(r) < 16 for r in UPPER.findall(instruction))


def legacy_sse(instructions):
    """Whether any instruction is SSE without the VEX encoding (the code
    that pays for an upper half left set)."""
    return any("%xmm" in i and not i.startswith("v") for _, i in instructions)


def dirty_exits(name, instructions, entry_dirty=False, avx_only=(),
                called_dirty=None):
    """The returns, tail calls and calls of @name reached with an upper
    half possibly set (a may-analysis over its jumps). A call to a
    function of @avx_only (VEX-encoded through and through: nothing there
    waits on the halves) may pass them set, as clang does when it turns
    pointer arguments into 256-bit ones: the callee is added to
    @called_dirty, to be followed from a dirty entry in turn. A callee
    returns clean, as the ABI has it, and is checked on its own."""
    index = {a: k for k, (a, _) in enumerate(instructions)}
    reached = [None] * len(instructions)
    problems = set()
    table_state = None          # at a jump through a table, if any
    work = [(0, entry_dirty)]
    while True:
        while work:
            k, dirty = work.pop()
            while k < len(instructions):
                if reached[k] is not None and (reached[k] or not dirty):
                    break
                reached[k] = dirty = dirty or bool(reached[k])
                address, instruction = instructions[k]
                op = instruction.split()[0]
                if op in ("vzeroupper", "vzeroall"):
                    dirty = False
                elif touches_upper(instruction):
                    dirty = True
                if op.startswith("ret"):
                    if dirty:
                        problems.add((address, instruction))
                    break
                if op.startswith("call"):
                    callee = DIRECT.match(instruction)
                    if dirty and callee and callee.group(2) in avx_only:
                        if called_dirty is not None:
                            called_dirty.add(callee.group(2))
                    elif dirty:
                        problems.add((address, instruction))
                    dirty = False
                if op.startswith("j") or op == "notrack":
                    target = DIRECT.match(instruction)
                    if target and target.group(2) == name \
                            and int(target.group(1), 16) in index:
                        work.append((index[int(target.group(1), 16)], dirty))
                    elif "*" in instruction and ("notrack" in instruction
                                                 or "," in instruction):
                        table_state = bool(table_state) or dirty
                    elif op in ("jmp", "notrack"):
                        if dirty and target and target.group(2) in avx_only:
                            if called_dirty is not None:
                                called_dirty.add(target.group(2))
                        elif dirty:
                            problems.add((address, instruction + " (tail)"))
                    if "jmp" in instruction:
                        break
                k += 1
        # A jump table's targets: every instruction not reached otherwise.
        if table_state is None:
            break
        work = [(k, table_state) for k, s in enumerate(reached)
                if s is None or (table_state and not s)]
        if not work:
            break
    return sorted(problems)


def disassemble(path):
    if not shutil.which("objdump"):
        raise Skip("no objdump (binutils)")
    text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", path],
                          check=True, capture_output=True, text=True).stdout
    if "x86-64" not in text:
        raise Skip("not an x86-64 build: no AVX kernels")
    return text


@test
def kernels_clean():
    """every function of the kernels' library using ymm or zmm registers
    returns, tail-calls and calls out with their upper halves clear"""
    found = functions(disassemble(LIBRARY))
    wide = {n: i for n, i in found.items()
            if any(touches_upper(x) for _, x in i)}
    print(f"# {len(wide)} functions use ymm or zmm: {' '.join(sorted(wide))}")
    assert "rank_pass_avx2" in wide and "rank_pass_avx512" in wide, \
        "the AVX kernels were not found"
    avx_only = {n for n, i in found.items() if not legacy_sse(i)}
    entered_dirty = set()
    while True:
        called = set()
        bad = {n: dirty_exits(n, i, n in entered_dirty, avx_only, called)
               for n, i in found.items()
               if n in wide or n in entered_dirty}
        if called <= entered_dirty:
            break
        entered_dirty |= called
    if entered_dirty:
        print(f"# called with upper halves set (VEX code only): "
              f"{' '.join(sorted(entered_dirty))}")
    bad = {n: p for n, p in bad.items() if p}
    for n, p in sorted(bad.items()):
        for address, instruction in p:
            print(f"# {n} at {address:x}: {instruction}, upper halves set")
    assert not bad, f"no vzeroupper before leaving {', '.join(sorted(bad))}"


@test
def check_finds_dirty():
    """the check finds an upper half left set at a return, a tail call
    and a call out of VEX code, and none after a vzeroupper on every
    path"""
    dirty_return = functions("""
0000000000000000 <f>:
   0:	vaddps %ymm1,%ymm0,%ymm0
   4:	test   %edi,%edi
   6:	je     c <f+0xc>
   8:	vzeroupper
   b:	ret
   c:	ret
""")["f"]
    assert [a for a, _ in dirty_exits("f", dirty_return)] == [0xc]
    tail = functions("""
0000000000000000 <g>:
   0:	vmovaps (%rdi),%ymm0
   4:	jmp    100 <h>
""")["g"]
    assert len(dirty_exits("g", tail)) == 1
    call = functions("""
0000000000000000 <g>:
   0:	vmovaps (%rdi),%ymm0
   4:	call   100 <h>
   9:	ret
""")["g"]
    assert [a for a, _ in dirty_exits("g", call)] == [0x4]
    called = set()
    assert dirty_exits("g", call, avx_only={"h"}, called_dirty=called) == []
    assert called == {"h"}
    assert legacy_sse(functions("""
0000000000000000 <h>:
   0:	mulss  %xmm1,%xmm0
   4:	ret
""")["h"])
    clean = functions("""
0000000000000000 <k>:
   0:	vmovaps (%rdi),%zmm0
   6:	jne    e <k+0xe>
   8:	vzeroupper
   b:	call   100 <h>
   e:	vzeroupper
  11:	ret
""")["k"]
    assert dirty_exits("k", clean) == []


if __name__ == "__main__":
    sys.exit(run_all())
