// Mark the table wrappers whose table is wider than the page (see spine_docs.css).
function spineDocsMarkWideTables() {
  document.querySelectorAll(".table-wrapper").forEach(function (w) {
    w.classList.toggle("is-wide", w.scrollWidth > w.clientWidth + 1);
  });
}
window.addEventListener("load", spineDocsMarkWideTables);
window.addEventListener("resize", spineDocsMarkWideTables);
