# SPDX-License-Identifier: BSD-2-Clause
"""A context's fields are written only by its own module (docs/design.md,
"Records and their owners"): the records of app_ctx (src/solver/app_context.F90)
are assigned, allocated or taken as a writable dummy argument only in the
module that owns each; every other module reads them or calls the owner's
routines. A pure scan of src/ (no build, no run): it lists every offending
statement with its file and line. What it cannot see: a record's field
passed as an actual argument to another module's procedure that writes
it (the procedure's intent is in another file); a procedure that takes a
whole record writable outside the owner is found by its declaration."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"

# app_ctx's component (a path of components below any variable) -> the
# module that owns it. The longest path wins: the Newton start's kept states
# are a record inside the newton record, owned by module newton_start.
OWNERS = {
    ("model",): "cloth_model",
    ("asm",): "cloth_model",
    ("newton",): "newton_policy",
    ("newton", "start"): "newton_start",
    ("step",): "step_monitor",
    ("energy",): "step_monitor",
    ("progress",): "step_monitor",
    ("restart",): "run_checkpoint",
    ("red",): "reduced",
    ("contact",): "contact_forces",
}
# The records' types -> their owner: only there may a procedure take one as
# a dummy argument it can write (intent out or inout, or no intent), or
# declare one (outside a derived type's components: app_ctx's).
TYPE_OWNERS = {
    "model_state_t": "cloth_model",
    "assembly_t": "cloth_model",
    "newton_state_t": "newton_policy",
    "newton_start_t": "newton_start",
    "step_settings_t": "step_monitor",
    "energy_integrals_t": "step_monitor",
    "progress_t": "step_monitor",
    "restart_state_t": "run_checkpoint",
    "reduced_t": "reduced",
    "contact_state_t": "contact_forces",
}
def strip_comment(line):
    """The line without its ! comment and with string literals blanked."""
    out, quote = [], None
    for ch in line:
        if quote:
            out.append(" ")
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
            out.append(" ")
        elif ch == "!":
            break
        else:
            out.append(ch)
    return "".join(out)


def statements(text):
    """(first line number, statement) of a free-form source: continuation
    lines joined, comments dropped, ';' splitting statements."""
    joined, start, pending = [], None, ""
    for n, raw in enumerate(text.splitlines(), 1):
        if raw.lstrip().startswith("#"):          # preprocessor line
            continue
        line = strip_comment(raw).rstrip()
        if not pending:
            start = n
        body = line.lstrip()
        if pending and body.startswith("&"):
            body = body[1:]
        if body.endswith("&"):
            pending += body[:-1] + " "
            continue
        pending += body
        for part in pending.split(";"):
            if part.strip():
                joined.append((start, part.strip()))
        pending = ""
    return joined


def split_top(s, seps):
    """Positions in s of the characters in seps at parenthesis depth 0."""
    depth, pos = 0, []
    for i, ch in enumerate(s):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0 and ch in seps:
            pos.append(i)
    return pos


def skip_parens(s, i):
    """Index after the balanced parenthesis group that starts at s[i]."""
    depth = 0
    for j in range(i, len(s)):
        if s[j] == "(":
            depth += 1
        elif s[j] == ")":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(s)


def assigned_designators(stmt):
    """The variables a statement writes: the left side of an assignment
    (= or =>, also after a one-line if or where) and the objects of
    allocate, deallocate and nullify."""
    s = stmt
    m = re.match(r"(?i)(else\s+)?(if|where)\s*\(", s)
    while m:
        s = s[skip_parens(s, m.end() - 1):].strip()
        if re.fullmatch(r"(?i)then", s):
            return []
        m = re.match(r"(?i)(if|where)\s*\(", s)
    m = re.match(r"(?i)associate\s*\(", s)
    if m:
        # an alias can be written through: its target counts as written
        return re.findall(r"=>\s*([\w%]+(?:\([^()]*\))?(?:%\w+)*)", s)
    m = re.match(r"(?i)(allocate|deallocate|nullify)\s*\(", s)
    if m:
        inner = s[m.end():skip_parens(s, m.end() - 1) - 1]
        cuts = [-1] + split_top(inner, ",") + [len(inner)]
        items = [inner[a + 1:b].strip() for a, b in zip(cuts, cuts[1:])]
        return [x for x in items if not re.match(r"(?i)(stat|errmsg|source|mold)\s*=", x)]
    if re.match(r"(?i)(do|forall)\b", s) or "::" in s:
        return []
    for i in split_top(s, "="):
        before = s[i - 1] if i > 0 else ""
        after = s[i + 1] if i + 1 < len(s) else ""
        if before in "=/<>" or after == "=":
            continue
        return [s[:i].strip()]
    return []


def components(designator):
    """The component names of a designator, subscripts dropped:
    'ctx%model%fixed(i, j)' -> ['ctx', 'model', 'fixed']."""
    out, depth = [], 0
    flat = []
    for ch in designator:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0:
            flat.append(ch)
    for part in "".join(flat).split("%"):
        out.append(part.strip().lower())
    return out


def app_names(texts):
    """The names declared type(app_ctx) anywhere (variables, dummies,
    components: ctx, app)."""
    names = set()
    for text in texts:
        for _, stmt in statements(text):
            m = re.match(r"(?i)type\s*\(\s*app_ctx\s*\).*::(.*)", stmt)
            if m:
                for item in m.group(1).split(","):
                    names.add(re.match(r"\s*(\w*)", item).group(1).lower())
    return names - {""}


def record_owner(comps, apps):
    """The owner of the record a written designator reaches into, or None:
    a record is a component of an app_ctx (a name in apps: ctx%newton%cquad,
    ctx%newton, id%app%red%eta; not a dummy argument named like a record,
    nor another type's component of that name, as ctx%cfg%contact%stiffness)."""
    best = None
    for i in range(1, len(comps)):
        if comps[i - 1] not in apps:
            continue
        for path, owner in OWNERS.items():
            if tuple(comps[i:i + len(path)]) == path and (best is None or len(path) > best[0]):
                best = (len(path), owner, "%".join(comps[i:i + len(path)]))
    return best


def module_of(text):
    """The module a source file belongs to (a submodule: its ancestor)."""
    m = re.search(r"(?im)^\s*submodule\s*\(\s*(\w+)", text)
    if m:
        return m.group(1).lower()
    m = re.search(r"(?im)^\s*module\s+(?!procedure\b|subroutine\b|function\b)(\w+)", text)
    return m.group(1).lower() if m else None


def violations_in(text, name, apps):
    """Each statement of the file that writes a record outside its owner
    (apps: the names of app_ctx variables and components)."""
    module = module_of(text)
    found = []
    in_type = False
    for line, stmt in statements(text):
        if re.match(r"(?i)type\b\s*(,[^:]*)?(::)?\s*\w+$", stmt) and not stmt.lower().startswith("type("):
            in_type = True                       # a derived type's definition: components follow
        elif re.match(r"(?i)end\s*type\b", stmt):
            in_type = False
        hits = {record_owner(components(d), apps) for d in assigned_designators(stmt)}
        for hit in sorted(h for h in hits if h and h[1] != module):
            found.append(f"{name}:{line}: {stmt}   [{hit[2]} is module {hit[1]}'s]")
        m = re.match(r"(?i)type\s*\(\s*(\w+)\s*\)(.*)::", stmt)
        if m and m.group(1).lower() in TYPE_OWNERS and not in_type:
            owner = TYPE_OWNERS[m.group(1).lower()]
            attrs = m.group(2).lower().replace(" ", "")
            if module != owner and "intent(in)" not in attrs:
                found.append(f"{name}:{line}: {stmt}   [a writable {m.group(1)}: module {owner}'s]")
    return found


def source_files():
    return sorted(p for p in SRC.rglob("*") if p.suffix.lower() in (".f90",))


def test_records_are_written_only_by_their_owners():
    files = source_files()
    assert any(p.name == "app_context.F90" for p in files)
    texts = {p: p.read_text() for p in files}
    apps = app_names(texts.values())
    assert {"ctx", "app"} <= apps
    found = []
    for p in files:
        found += violations_in(texts[p], str(p.relative_to(ROOT)), apps)
    assert not found, "records written outside their owning module:\n" + "\n".join(found)


def test_owners_and_types_exist():
    """The table above names real modules and real types of app_ctx (a
    renamed module or record would otherwise make the scan pass vacuously)."""
    modules = {module_of(p.read_text()) for p in source_files()}
    assert set(OWNERS.values()) <= modules
    ctx = (SRC / "solver" / "app_context.F90").read_text().lower()
    body = ctx[ctx.index("type :: app_ctx"):ctx.index("end type app_ctx")]
    for path in OWNERS:
        assert re.search(r"::\s*" + path[0] + r"\b", body), path
    sources = "".join(p.read_text().lower() for p in source_files())
    for t in TYPE_OWNERS:
        assert re.search(r"type\s*::\s*" + t + r"\b", sources), t


def test_the_scan_finds_writes():
    """The scanner itself: each form of write outside the owner is found,
    reads and the owner's own writes are not."""
    text = """module timestepping
contains
  subroutine s(ctx, n)
    type(app_ctx), intent(inout) :: ctx
    type(newton_state_t), intent(inout) :: n
    type(progress_t), intent(in) :: p
    ctx%newton%cquad = 0.0_rp
    if (ctx%step%fixed_step) h = ctx%step%dt
    if (x > 0) ctx%model%fixed(i, &
      j) = .true.
    allocate(ctx%model%f(3, n))
    ctx%newton%start%n = 0
    ctx%progress = progress_t()
    call f(ctx%energy%t_prev == t, a=ctx%restart%t_restart)
    id%app%red%eta = 1; ctx%asm%jbuf%k(:, :, slot_of(j)) = 0
    x = merge(ctx%red%floor_est, 0.0_rp, ctx%use_reduced)
    ctx%cfg%contact%stiffness = 0; red%eta = 0
    b = ctx%newton%cquad /= 0 ! ctx%newton%cquad = 1
    associate (m => ctx%model)
  end subroutine s
  type :: r_t
    type(newton_state_t) :: n
  end type r_t
  type(newton_state_t) :: kept
end module timestepping
"""
    def lines(found):
        return sorted(int(f.split(":")[1]) for f in found)
    apps = app_names([text]) | {"app"}
    assert apps == {"ctx", "app"}
    assert lines(violations_in(text, "t.F90", apps)) == [5, 7, 9, 11, 12, 13, 15, 15, 19, 24]
    # in the newton record's own module its fields and its type are its
    # own, the Newton start's kept states (newton%start) are not
    owner = text.replace("module timestepping", "module newton_policy")
    assert lines(violations_in(owner, "t.F90", apps)) == [9, 11, 12, 13, 15, 15, 19]
