"""Screenshots of `sgt lsp` in Neovim for docs/editors.md: Neovim in tmux with the shipped
set-up (editors/neovim/sgt.lua), its screen captured with `tmux capture-pane -e` and drawn to
PNG with Pillow (colours and bold kept).

    python editors/neovim/screenshots.py [OUT_DIR]     # default editors/screenshots

Makes nvim-diagnostics.png, nvim-completion.png and nvim-hover.png. Needs nvim, tmux and the
DejaVu Sans Mono font (Debian: fonts-dejavu-core).
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image, ImageDraw, ImageFont

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
COLS, ROWS = 104, 26
FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf"
BOLD = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono-Bold.ttf"
SIZE = 15

SCRIPT = """\
# A mall-guide robot greets a visitor and gives directions.
@voice en-us
@rate 160
@preset helpful = speed:+0.5 space:+1

guide: [pose:wave] Hello, and welcome to Riverside Mall! <helpful>I can help you.</>
guide: Look at the shelf [pose:point_rigth x2] <speed:-1>over there</speed>, on your right.
guide: The food court is [pose:point_up] upstairs, and the cinema is [pause 400]
    [pose:point_right flip] over to the left.
visitor: Thank you!
"""
INIT = """\
vim.cmd("set noswapfile shortmess+=I laststatus=2 signcolumn=yes number termguicolors nowrap completeopt=menuone,noinsert")
vim.cmd("syntax on")
vim.cmd([[
hi Normal guibg=#181a1f guifg=#dcdcdc
hi NormalFloat guibg=#262a33 guifg=#dcdcdc
hi FloatBorder guibg=#262a33 guifg=#7f8490
hi Pmenu guibg=#262a33 guifg=#dcdcdc
hi PmenuSel guibg=#3e4452 guifg=#ffffff gui=bold
hi PmenuSbar guibg=#262a33
hi PmenuThumb guibg=#5c6370
hi SignColumn guibg=#181a1f
hi LineNr guifg=#5c6370
hi EndOfBuffer guifg=#3e4452
hi StatusLine guibg=#3e4452 guifg=#dcdcdc gui=NONE
hi DiagnosticError guifg=#e06c75
hi DiagnosticWarn guifg=#e5c07b
hi DiagnosticUnderlineError gui=undercurl guisp=#e06c75
]])
dofile("{lua}").setup({{ cmd = {{ "{python}", "-m", "sgt_tui.cli", "lsp" }} }})
vim.diagnostic.config({{ virtual_text = true, signs = true, underline = true, float = {{ border = "single" }} }})
vim.lsp.handlers["textDocument/hover"] = vim.lsp.with(vim.lsp.handlers.hover, {{ border = "single" }})
"""

# xterm's 16 colours, then the 256-colour cube and greys
_BASE16 = [(0, 0, 0), (205, 49, 49), (13, 188, 121), (229, 229, 16), (36, 114, 200), (188, 63, 188), (17, 168, 205),
           (229, 229, 229), (102, 102, 102), (241, 76, 76), (35, 209, 139), (245, 245, 67), (59, 142, 234),
           (214, 112, 214), (41, 184, 219), (255, 255, 255)]
FG, BG = (220, 220, 220), (24, 26, 31)


def _color256(n: int) -> tuple[int, int, int]:
    if n < 16:
        return _BASE16[n]
    if n < 232:
        n -= 16
        steps = [0, 95, 135, 175, 215, 255]
        return steps[n // 36], steps[(n // 6) % 6], steps[n % 6]
    g = 8 + 10 * (n - 232)
    return g, g, g


def _cells(text: str) -> list[list[tuple[str, tuple, tuple, bool]]]:
    """The captured screen as rows of (character, foreground, background, bold)."""
    rows = []
    fg, bg, bold, reverse = FG, BG, False, False
    for line in text.split("\n")[:ROWS]:
        row = []
        for part in re.split(r"(\x1b\[[0-9;]*m)", line):
            if part.startswith("\x1b["):
                codes = [int(c) if c else 0 for c in part[2:-1].split(";")]
                i = 0
                while i < len(codes):
                    c = codes[i]
                    if c == 0:
                        fg, bg, bold, reverse = FG, BG, False, False
                    elif c == 1:
                        bold = True
                    elif c == 22:
                        bold = False
                    elif c == 7:
                        reverse = True
                    elif c == 27:
                        reverse = False
                    elif 30 <= c <= 37 or 90 <= c <= 97:
                        fg = _BASE16[c - 30 if c < 90 else c - 82]
                    elif 40 <= c <= 47 or 100 <= c <= 107:
                        bg = _BASE16[c - 40 if c < 100 else c - 92]
                    elif c == 39:
                        fg = FG
                    elif c == 49:
                        bg = BG
                    elif c in (38, 48) and i + 1 < len(codes):
                        if codes[i + 1] == 5 and i + 2 < len(codes):
                            color, i = _color256(codes[i + 2]), i + 2
                        elif codes[i + 1] == 2 and i + 4 < len(codes):
                            color, i = tuple(codes[i + 2 : i + 5]), i + 4
                        else:
                            color = FG if c == 38 else BG
                        if c == 38:
                            fg = color
                        else:
                            bg = color
                    i += 1
                continue
            for ch in part:
                f, b = (bg, fg) if reverse else (fg, bg)
                row.append((ch, f, b, bold))
        rows.append(row)
    return rows


#: The dot of each bit of a braille character: (column, row) in its 2 x 4 grid.
_DOTS = ((0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (0, 3), (1, 3))


def _braille(draw, bits: int, px: int, py: int, w: int, h: int, fg) -> None:
    r = max(1, w // 6)
    for bit, (cx, cy) in enumerate(_DOTS):
        if bits & (1 << bit):
            x, y = px + w * (1 + 2 * cx) // 4, py + h * (1 + 2 * cy) // 8
            draw.ellipse([x - r, y - r, x + r, y + r], fill=fg)


def render(text: str, out: Path) -> None:
    font, bold_font = ImageFont.truetype(FONT, SIZE), ImageFont.truetype(BOLD, SIZE)
    w = round(font.getlength("M"))
    h = SIZE + 5
    img = Image.new("RGB", (COLS * w + 16, ROWS * h + 16), BG)
    draw = ImageDraw.Draw(img)
    for y, row in enumerate(_cells(text)):
        for x, (ch, fg, bg, bold) in enumerate(row[:COLS]):
            px, py = 8 + x * w, 8 + y * h
            if bg != BG:
                draw.rectangle([px, py, px + w - 1, py + h - 1], fill=bg)
            if 0x2800 <= ord(ch) <= 0x28FF:  # braille (the figures): drawn as dots, few fonts have them
                _braille(draw, ord(ch) - 0x2800, px, py, w, h, fg)
            elif ch.strip():
                draw.text((px, py + 1), ch, font=bold_font if bold else font, fill=fg)
    img.save(out)


def _tmux(*args: str) -> str:
    return subprocess.run(["tmux", *args], check=True, capture_output=True, text=True).stdout


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "editors" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="sgt-nvim-"))
    (work / "mall.sgt").write_text(SCRIPT, encoding="utf-8")
    (work / "init.lua").write_text(INIT.format(lua=HERE / "sgt.lua", python=sys.executable), encoding="utf-8")
    session = "sgt-shots"
    subprocess.run(["tmux", "kill-session", "-t", session], check=False, capture_output=True)
    _tmux("new-session", "-d", "-s", session, "-x", str(COLS), "-y", str(ROWS), "-c", str(work),
          f"env TERM=xterm-256color nvim --clean -u {work / 'init.lua'} {work / 'mall.sgt'}")
    try:
        time.sleep(4)  # the server starts and publishes its diagnostics

        def keys(*k: str, wait: float = 1.0) -> None:
            _tmux("send-keys", "-t", session, *k)
            time.sleep(wait)

        def shot(name: str) -> None:
            render(_tmux("capture-pane", "-p", "-e", "-t", session), out / name)
            print(out / name)

        keys(":7", "Enter", wait=0.5)
        keys(":lua vim.diagnostic.open_float()", "Enter", wait=1.5)
        shot("nvim-diagnostics.png")
        keys("Escape", ":10", "Enter", "A", wait=0.5)
        keys(" [pose:po", wait=0.5)
        keys("C-x", "C-o", wait=2.0)
        shot("nvim-completion.png")
        keys("Escape", "u", ":6", "Enter", "0", "f", "w", wait=0.5)
        keys(":lua vim.lsp.buf.hover()", "Enter", wait=2.0)
        shot("nvim-hover.png")
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], check=False, capture_output=True)


if __name__ == "__main__":
    main()
