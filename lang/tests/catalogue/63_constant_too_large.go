// Constant arithmetic that leaves the range of numbers.
package TooLarge

const Big = 1e308 * 10

var D1 Quadcopter

func INIT() {
	D1.FlyByX(Big)
}
