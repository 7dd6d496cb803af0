// Typesets the maths of pymdownx.arithmatex (generic mode: \( \) inline, \[ \] display)
// with the KaTeX bundled under vendor/katex/, so pages render without network.
// Material's document$ fires on every page load, instant navigation included.
document$.subscribe(({ body }) => {
  for (const node of body.querySelectorAll(".arithmatex")) {
    renderMathInElement(node, {
      delimiters: [
        { left: "\\[", right: "\\]", display: true },
        { left: "\\(", right: "\\)", display: false }
      ],
      throwOnError: false
    });
  }
});
