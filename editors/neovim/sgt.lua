-- sgt for Neovim 0.7+ with its built-in LSP client and no plugins: `.sgt` files get the
-- filetype "sgt" and the language server `sgt lsp` (diagnostics, completion, hover, go to
-- definition, references, rename, code actions, formatting, symbols...).
--
--   -- in init.lua (the path is where this repository is):
--   dofile("/path/to/sgt/editors/neovim/sgt.lua").setup()
--   -- options: { cmd = { "sgt", "lsp" }, root_markers = { ".git", "sgt.toml" } }
--
-- With nvim-lspconfig instead, see docs/editors.md. The sgt.preview command (a GIF of the
-- utterance at the cursor) is mapped by `setup` to :SgtPreview.
local M = {}

local function root_of(path, markers)
  for _, marker in ipairs(markers) do
    local found = vim.fn.finddir(marker, vim.fn.fnamemodify(path, ":p:h") .. ";")
    if found == "" then
      found = vim.fn.findfile(marker, vim.fn.fnamemodify(path, ":p:h") .. ";")
    end
    if found ~= "" then
      return vim.fn.fnamemodify(found, ":p:h:h")
    end
  end
  return vim.fn.fnamemodify(path, ":p:h")
end

function M.setup(opts)
  opts = opts or {}
  local cmd = opts.cmd or { "sgt", "lsp" }
  local markers = opts.root_markers or { ".git", "sgt.toml" }
  local clients = {}
  local group = vim.api.nvim_create_augroup("sgt", { clear = true })
  -- syntax/sgt.vim next to this file: highlighting before (and besides) the server's
  local here = debug.getinfo(1, "S").source:sub(2):match("(.*/)")
  if here then
    vim.opt.runtimepath:append(here)
  end
  vim.api.nvim_create_autocmd({ "BufRead", "BufNewFile" }, {
    group = group, pattern = "*.sgt", command = "setlocal filetype=sgt commentstring=#\\ %s",
  })
  vim.api.nvim_create_autocmd("FileType", {
    group = group,
    pattern = "sgt",
    callback = function(args)
      local root = root_of(vim.api.nvim_buf_get_name(args.buf), markers)
      if clients[root] == nil or vim.lsp.get_client_by_id(clients[root]) == nil then
        clients[root] = vim.lsp.start_client({
          name = "sgt", cmd = cmd, root_dir = root,
          workspace_folders = { { uri = vim.uri_from_fname(root), name = root } },
        })
      end
      vim.lsp.buf_attach_client(args.buf, clients[root])
      vim.bo[args.buf].omnifunc = "v:lua.vim.lsp.omnifunc"
    end,
  })
  vim.api.nvim_create_user_command("SgtPreview", function()
    local params = { uri = vim.uri_from_bufnr(0), line = vim.api.nvim_win_get_cursor(0)[1] - 1 }
    vim.lsp.buf_request(0, "workspace/executeCommand", { command = "sgt.preview", arguments = { params } },
      function(err, result)
        if err then
          vim.notify("sgt.preview: " .. err.message, vim.log.levels.WARN)
        else
          vim.notify("sgt.preview: " .. result.gif)
        end
      end)
  end, {})
end

return M
