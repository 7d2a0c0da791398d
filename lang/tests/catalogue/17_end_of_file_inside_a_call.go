// The file ends in the middle of a call.
package Truncated

var D1 Quadcopter

func INIT() {
	RepeatWhile(D1.X() < 10 &&
