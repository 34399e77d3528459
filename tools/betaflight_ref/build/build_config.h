/* Host stub (skyloop tools): the maths source includes this header but needs nothing from it. */
#pragma once
