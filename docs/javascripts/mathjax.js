// MathJax configuration for pymdownx.arithmatex (generic mode). MathJax itself is served by the site
// (javascripts/mathjax/tex-chtml-full.js, loaded after this file): equations render offline.
window.MathJax = {
  tex: {inlineMath: [["\\(", "\\)"]], displayMath: [["\\[", "\\]"]], processEscapes: true, processEnvironments: true},
  options: {ignoreHtmlClass: ".*|", processHtmlClass: "arithmatex"},
};
// Material's document$ emits the first page, then each page reached by instant navigation. MathJax's
// own start-up typesets the first page: clearing its cache then (when MathJax loaded before document$
// emitted, as it does from the site itself) would drop the glyphs' CSS and leave the equations blank.
let mathjaxFirstPage = true;
document$.subscribe(() => {
  if (mathjaxFirstPage) { mathjaxFirstPage = false; return; }
  if (window.MathJax && MathJax.typesetPromise) {
    MathJax.startup.promise = MathJax.startup.promise.then(() => {
      MathJax.startup.output.clearCache(); MathJax.typesetClear(); MathJax.texReset();
      return MathJax.typesetPromise();
    });
  }
});
