" Vim/Neovim syntax for .sgt scripts (editors/neovim/sgt.lua puts this folder on the
" runtimepath). The language server's semantic tokens refine it where the editor uses them.
if exists("b:current_syntax")
  finish
endif

syntax match sgtEscape /\\./
syntax match sgtComment /#.*$/ contains=@Spell
syntax match sgtDirective /^@[A-Za-z_][A-Za-z0-9_-]*/ nextgroup=sgtDirectiveArgs
syntax match sgtDirectiveArgs /.*/ contained contains=sgtComment,sgtEscape
syntax match sgtSpeaker /^[^ \t@#:\[\]<>0-9][^ \t:\[\]<>]*\ze[ \t]*:\([ \t]\|$\)/
syntax match sgtTag /\[[ \t]*[A-Za-z_][A-Za-z0-9_-]*[^\]\[<>]*\]/ contains=sgtTagKind,sgtGesture,sgtOption
syntax match sgtTagKind /\[\@<=[ \t]*[A-Za-z_][A-Za-z0-9_-]*/ contained
syntax match sgtGesture /:[ \t]*\zs[A-Za-z_][A-Za-z0-9_-]*/ contained
syntax match sgtOption /[ \t]\zs[A-Za-z0-9_.+-]\+\([ \t]*=[ \t]*[A-Za-z0-9_.+-]\+\)\?/ contained
syntax match sgtStyle /<\/\?[ \t]*\([A-Za-z_][A-Za-z0-9_-]*\([ \t]*:[ \t]*[A-Za-z0-9_.+-]\+\)\?[ \t]*\)*>/ contains=sgtStyleName,sgtStyleValue
syntax match sgtStyleName /[A-Za-z_][A-Za-z0-9_-]*/ contained
syntax match sgtStyleValue /:[ \t]*\zs[A-Za-z0-9_.+-]\+/ contained

highlight default link sgtComment Comment
highlight default link sgtDirective PreProc
highlight default link sgtDirectiveArgs Constant
highlight default link sgtSpeaker Type
highlight default link sgtTag Delimiter
highlight default link sgtTagKind Keyword
highlight default link sgtGesture Function
highlight default link sgtOption Constant
highlight default link sgtStyle Delimiter
highlight default link sgtStyleName Function
highlight default link sgtStyleValue Number
highlight default link sgtEscape SpecialChar

let b:current_syntax = "sgt"
